#!/usr/bin/env python3
"""Timed Mitsuba 3 renders of scenes exported by `rtdiff export SCENE --to mitsuba -o DIR`, for
`rtdiff report convergence` (src/perf/mitsuba_python.rs is the one place that runs this script).

  .venv/bin/python scripts/mitsuba/sweep.py JOBS.json

JOBS.json: {"variant": null or "scalar_rgb" | "llvm_ad_rgb",
            "renders": [{"scene_dir": DIR, "seeds": [S, ...], "outputs": [OUT.exr, ...],
                         "passes": P or null}, ...]}

Each scene is loaded once and warmed up by one pass (not written) that traces and compiles the JIT
kernels; then each seed is rendered (P passes, by default spp x dof_samples) into its output. Python
start-up, Mitsuba's import, the scene's load and the warm-up are outside the render times. One
JSON line per image on stdout:

  {"output": ..., "seed": S, "passes": P, "load_seconds": L, "warmup_seconds": W, "render_seconds": R}

render_seconds is the warm render: kernels compiled (or found in Dr.Jit's cache), the Python
integrator's tracing of each pass included (that is this plugin's cost); warmup_seconds is the
scene's one warm-up pass, compilation included. A final line {"mitsuba": version, "variant":
variant} closes the output.
"""
import json
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import rtdiff_mitsuba as rm  # noqa: E402


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: sweep.py JOBS.json")
    jobs_path = sys.argv[1]
    try:
        with open(jobs_path) as f:
            jobs = json.load(f)
        renders = jobs["renders"]
    except (OSError, ValueError, KeyError) as e:
        sys.exit(f"sweep.py: {jobs_path}: {e}")
    for job in renders:
        if not os.path.isfile(os.path.join(job["scene_dir"], "scene.xml")):
            sys.exit(f"sweep.py: {job['scene_dir']}: no scene.xml (make one with rtdiff export)")
        if len(job["seeds"]) != len(job["outputs"]):
            sys.exit(f"sweep.py: {job['scene_dir']}: one output per seed")
    mi = rm.setup(jobs.get("variant"))
    for job in renders:
        t0 = time.perf_counter()
        cfg = rm.config(job["scene_dir"])
        scene = rm.load(mi, job["scene_dir"])
        t1 = time.perf_counter()
        # The warm-up's seed is one the job does not use.
        rm.render(mi, scene, cfg, max(job["seeds"]) + 1, passes=1)
        t2 = time.perf_counter()
        for seed, output in zip(job["seeds"], job["outputs"]):
            t3 = time.perf_counter()
            img = rm.render(mi, scene, cfg, int(seed), job.get("passes"))
            t4 = time.perf_counter()
            rm.write_exr(output, img)
            print(json.dumps({
                "output": output,
                "seed": seed,
                "passes": job.get("passes") or int(cfg["spp"]) * int(cfg["dof_samples"]),
                "load_seconds": round(t1 - t0, 6),
                "warmup_seconds": round(t2 - t1, 6),
                "render_seconds": round(t4 - t3, 6),
            }), flush=True)
    print(json.dumps({"mitsuba": mi.__version__, "variant": mi.variant()}), flush=True)


if __name__ == "__main__":
    main()
