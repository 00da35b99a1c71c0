"""gmcpt.runtime.progress: a bar with rate and time left on a terminal, log lines elsewhere, nothing when quiet."""
import io

from gmcpt.runtime.progress import Progress, format_seconds, status_line


class Terminal(io.StringIO):
    def isatty(self):
        return True


def test_status_line_counts_rate_and_time_left():
    assert status_line("batch", 2, 8, 4.0, "frame", "cornell-box 1.9s") == \
        "batch 2/8 frames: cornell-box 1.9s (0.5 frame/s, 12s left)"
    assert status_line("train", 150, 200, 10.0, "step", initial=100) == "train 150/200 steps (5 step/s, 10s left)"
    assert status_line("dataset", 0, 3, 0.0, "scene") == "dataset 0/3 scenes (- scene/s, ? left)"
    assert status_line("eval", 4, None, 2.0, "scene") == "eval 4 scenes (2 scene/s)"
    assert [format_seconds(s) for s in (0.4, 59.6, 187, 7500, -1, float("inf"))] == \
        ["0s", "1m00s", "3m07s", "2h05m", "?", "?"]


def test_log_lines_off_a_terminal_and_silence_when_quiet():
    lines, stream = [], io.StringIO()
    with Progress(4, "batch", "frame", say=lines.append, stream=stream, log_every=2) as bar:
        bar.update(note="cornell-box 1.0s")   # not a 2nd update: no line
        bar.update()
        bar.update(note="still-life 3.0s")
        bar.update(note="breakfast-room 9.0s")
        bar.write("a message")
    assert len(lines) == 3 and lines[0].startswith("batch 2/4 frames (")
    assert lines[1].startswith("batch 4/4 frames: breakfast-room 9.0s (") and "left)" in lines[1]
    assert lines[2] == "a message" and stream.getvalue() == ""
    quiet = []
    with Progress(2, "batch", say=quiet.append, quiet=True, stream=Terminal()) as bar:
        bar.update(note="x")
        bar.write("y")
    assert quiet == [] and bar.done == 1


def test_a_terminal_gets_a_bar_with_rate_and_eta():
    terminal, lines = Terminal(), []
    with Progress(8, "batch", "frame", say=lines.append, stream=terminal) as bar:
        bar.update(note="cornell-box")
        bar.write("between")
    drawn = terminal.getvalue()
    assert lines == [] and "batch" in drawn and "1/8" in drawn and "frame/s" in drawn and "<" in drawn
    assert "between" in drawn and "cornell-box" in drawn
