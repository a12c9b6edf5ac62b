"""``make demo``: run the smoke suite with rendering and leave things to look at."""

from __future__ import annotations

from pathlib import Path

from tools.draw import draw_ground_truth, save_rgb
from tools.rundir import prepare_dir
from tools.suite import load_suite

ROOT = Path(__file__).resolve().parents[1]
KEY_FRAMES = (0.25, 0.5, 0.75)  # fractions of each run at which a PNG is kept


class KeyFrameSink:
    """Saves annotated PNGs of the frames nearest given fractions of the run."""

    def __init__(self, out: Path, frames_total: int) -> None:
        self.out, self.want = prepare_dir(out), {int(f * frames_total) for f in KEY_FRAMES}
        self.saved: list[Path] = []

    def on_start(self, info: dict) -> None: ...

    def on_tick(self, rec) -> None:
        if rec.frame_index in self.want and rec.frame.image is not None:
            path = self.out / f"frame_{rec.frame_index:04d}.png"
            save_rgb(path, draw_ground_truth(rec.frame.image, rec.ground_truth))
            self.saved.append(path)

    def on_end(self, summary: dict) -> None: ...


def run_demo(out: Path, console) -> dict:
    """The smoke suite rendered on two workers: run directories with key frames, one
    SQLite store, an annotated video and a rerun recording of the first scenario,
    and the HTML report of the whole suite."""
    from tools.report import build_report
    from tools.suite import run_suite

    suite = ROOT / "scenarios" / "suites" / "smoke.yaml"
    _, paths = load_suite(suite)
    outputs = {p.stem: ("keyframes",) for p in paths}
    outputs[paths[0].stem] = ("keyframes", "video", "rerun")
    db = prepare_dir(out) / "smoke.sqlite"
    if db.exists():
        db.unlink()
    summary = run_suite(suite, out, workers=2, render=True, db=db, outputs=outputs)
    report = build_report(out)
    from tools.cli import print_suite

    print_suite(summary)
    first = out / paths[0].stem
    console.print(f"report: {report}\nvideo: {first / 'annotated.mp4'}\nrerun: {first / 'run.rrd'}\n"
                  f"database: {db}", highlight=False)
    return summary
