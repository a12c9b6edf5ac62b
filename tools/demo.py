"""``make demo``: run the smoke suite with rendering and leave things to look at."""

from __future__ import annotations

import json
from pathlib import Path

from rich.table import Table

from sim.runner import Runner
from sim.scenario import load_scenario
from tools.draw import draw_ground_truth, save_rgb
from tools.rundir import RunDirWriter, prepare_dir
from tools.suite import load_suite

ROOT = Path(__file__).resolve().parents[1]
KEY_FRAMES = (0.25, 0.5, 0.75)  # fractions of each run at which a PNG is kept


class KeyFrameSink:
    """Saves annotated PNGs of the frames nearest given fractions of the run."""

    def __init__(self, out: Path, frames_total: int) -> None:
        self.out, self.want = out, {int(f * frames_total) for f in KEY_FRAMES}
        self.saved: list[Path] = []

    def on_start(self, info: dict) -> None: ...

    def on_tick(self, rec) -> None:
        if rec.frame_index in self.want and rec.frame.image is not None:
            path = self.out / f"frame_{rec.frame_index:04d}.png"
            save_rgb(path, draw_ground_truth(rec.frame.image, rec.ground_truth))
            self.saved.append(path)

    def on_end(self, summary: dict) -> None: ...


def run_demo(out: Path, console) -> dict:
    prepare_dir(out)
    name, paths = load_suite(ROOT / "scenarios" / "suites" / "smoke.yaml")
    table = Table(title=f"lookahead demo: suite '{name}'")
    for col in ("scenario", "frames", "t end (s)", "collision", "renderer", "key frames"):
        table.add_column(col)
    results = {}
    for path in paths:
        sc = load_scenario(path)
        run_dir = out / sc.name
        frames_total = int(sc.duration * sc.camera.rate)
        keys = KeyFrameSink(prepare_dir(run_dir / "frames"), frames_total)
        summary = Runner(sc, sinks=[RunDirWriter(run_dir, sc, str(path)), keys], render=True).run().to_dict()
        hit = summary["collisions"][0] if summary["collisions"] else None
        table.add_row(
            sc.name, str(summary["frames"]), f"{summary['t_end']:.2f}",
            f"{hit['name']} at {hit['ego_speed']:.1f} m/s" if hit else "-",
            str(summary["renderer"]), str(len(keys.saved)),
        )
        results[sc.name] = summary
    (out / "summary.json").write_text(json.dumps({"suite": name, "runs": results}, indent=2) + "\n")
    console.print(table)
    console.print(f"run directories and annotated frames in {out}", highlight=False)
    return results
