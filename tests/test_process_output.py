"""The test harness's capture of a process's output, read while the process still prints."""

import sys

from ros_test_support import NodeProcess


def test_output_read_while_the_process_prints_loses_nothing():
    """Reading the output (seek to the start, read) must not move where the process writes.

    The process and the reader share one open file; before the file was opened for appending,
    lines printed during a read overwrote earlier ones and a start-up line could vanish.
    """
    lines = 3000
    code = ('import time\n'
            f'for i in range({lines}):\n'
            '    print(f"line {i:05d} end", flush=True)\n'
            '    time.sleep(0.0002)\n')
    with NodeProcess([sys.executable, '-c', code], {}, 'printer') as printer:
        reads = 0
        while printer.process.poll() is None:
            printer.output  # noqa: B018 - polled as a test waiting for a line does
            reads += 1
        printed = printer.output.splitlines()
    assert reads > 10, 'the output was hardly read while the process printed'
    assert printed == [f'line {i:05d} end' for i in range(lines)]
