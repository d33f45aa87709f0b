"""Training progress: a line every few seconds in a log, a bar on a terminal."""

from __future__ import annotations

import io

import numpy as np

from pier_monitor.core.identify.methods import Progress
from pier_monitor.training_progress import TrainingProgress


def progress(epoch: int, max_epochs: int = 3000) -> Progress:
    k = np.array([1.2e9, 1.1e9])
    return Progress(epoch=epoch, max_epochs=max_epochs, loss=1.0 / epoch, terms={"data": 1.0},
                    k1=k, k2=k / 10, fy=k / 200, c=k / 100, elapsed_s=epoch / 30)


class FakeClock:
    """Seconds that the test sets: no dependence on the speed of the machine."""

    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def test_off_a_terminal_progress_is_a_line_per_interval_and_one_at_each_end() -> None:
    out, clock = io.StringIO(), FakeClock()
    with TrainingProgress(out, interval_s=9.99, tty=False, clock=clock) as report:
        for k, event in enumerate(("run1", "run2")):
            for epoch in range(1, 2001):  # 2000 epochs in 100 s
                clock.now = (k * 2000 + epoch) * 0.05
                report(event, progress(epoch))
    lines = out.getvalue().splitlines()
    assert len(lines) == 2 * (1 + 9 + 1)  # start, every 10 s, end
    assert lines[0] == "training run1: up to 3000 epochs"
    assert lines[1] == ("training run1: epoch 201/3000, loss 0.00498, k1 of section 1 "
                        "1.2e+09 N*m/rad, 7 s")
    assert lines[9].startswith("training run1: epoch 1801/3000")
    assert lines[10] == ("training run1: done after 2000/3000, loss 0.0005, k1 of section 1 "
                         "1.2e+09 N*m/rad, 67 s")
    assert lines[11] == "training run2: up to 3000 epochs"
    assert lines[-1].startswith("training run2: done after 2000/3000")


def test_on_a_terminal_progress_is_a_bar() -> None:
    out = io.StringIO()
    report = TrainingProgress(out, tty=True)
    for epoch in range(1, 51):
        report("run1", progress(epoch, max_epochs=50))
    report.close()
    text = out.getvalue()
    assert "training run1" in text and "50/50" in text and "\r" in text
    assert "done after" not in text
