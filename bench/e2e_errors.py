"""The error that stops bench/e2e_bench.sh at a step ("e2e_bench: FAILED
(step: reason)"), shared by e2e_bench.py and its step modules."""


class BenchError(Exception):
    def __init__(self, step, message):
        super().__init__(f"{step}: {message}")
