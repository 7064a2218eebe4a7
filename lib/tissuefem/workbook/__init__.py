"""The workbook layer: what the chapters, the instructor and the benchmarks need on top of the library.

* studies of the chapters: :mod:`.oned`, :mod:`.studies`, :mod:`.fibers`, :mod:`.hardcases`, :mod:`.timestepping`,
  :mod:`.procedures`, :mod:`.cracks`, :mod:`.verification`; the measuring tools of :mod:`.measure`, :mod:`.tables`;
* :mod:`.answers` -- the library's reference answers to the exercises;
* :mod:`.bench` -- the benchmarks (they measure and write results; they never draw);
* :mod:`.figures` -- every lecture figure as a function (they draw; recorded results are read, never rerun);
* :mod:`.notebooks` and :mod:`.cli` -- executing the chapters and the command line.
"""
