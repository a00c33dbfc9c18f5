# SPDX-License-Identifier: MIT
# Ctrl-C during a detection raises KeyboardInterrupt, promptly.
import os
import signal
import subprocess
import sys
import textwrap
import time

SCRIPT = textwrap.dedent("""
    import signal, sys, time
    import numpy as np
    import ced
    signal.signal(signal.SIGINT, signal.default_int_handler)  # also when started with SIGINT ignored
    pts = np.random.default_rng(1).random((20000, 3))
    def slow(points, offsets, neighbors):  # 0.5 s a block: the whole run would take about 30 s
        if not slow.started:
            slow.started = True
            print("started", flush=True)
        time.sleep(0.5)
        return np.zeros(len(points))
    slow.started = False
    try:
        ced.detect(pts, modalities=["xyz", ced.python_modality("slow", slow, 1.0)], radius=0.05, threads=1)
        print("finished")
    except KeyboardInterrupt:
        print("interrupted")
        sys.exit(3)
""")


def test_ctrl_c_raises_keyboard_interrupt():
    proc = subprocess.Popen([sys.executable, "-c", SCRIPT], stdout=subprocess.PIPE, text=True, env=os.environ)
    assert proc.stdout.readline().strip() == "started"
    time.sleep(0.2)
    proc.send_signal(signal.SIGINT)
    try:
        out, _ = proc.communicate(timeout=20)  # the whole run would take about 30 s (64 blocks)
    except subprocess.TimeoutExpired:
        proc.kill()
        raise AssertionError("the detection did not stop on SIGINT")
    assert out.strip() == "interrupted" and proc.returncode == 3
