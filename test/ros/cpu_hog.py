#!/usr/bin/env python3
"""Keeps every core busy until it is stopped (rostests of a saturated CPU):
one busy process per core, at normal priority."""
import multiprocessing
import os
import signal
import sys


def spin():
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    while True:
        pass


if __name__ == '__main__':
    workers = [multiprocessing.Process(target=spin, daemon=True) for _ in range(os.cpu_count() or 1)]
    for w in workers:
        w.start()

    def stop(*_):
        for w in workers:
            w.terminate()
        sys.exit(0)
    signal.signal(signal.SIGTERM, stop)
    signal.signal(signal.SIGINT, stop)
    signal.pause()
