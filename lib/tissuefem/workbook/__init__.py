"""The workbook layer on top of the library: the chapters' studies (:mod:`.oned` ... :mod:`.verification`) and
measuring tools (:mod:`.measure`, :mod:`.tables`), the exercises' answers (:mod:`.answers`), the benchmarks
(:mod:`.bench`: they measure, never draw), the lecture figures (:mod:`.figures`: they draw, never rerun a
benchmark), and running the chapters (:mod:`.notebooks`) and the command line (:mod:`.cli`)."""
