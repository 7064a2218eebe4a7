"""Benchmarks: assembly, the real-time frame, the cost of each effect, and the accuracy/time study."""
