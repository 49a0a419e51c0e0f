"""luz's samplers against Mitsuba 3's on one peer scene of ../shared/SCENES.md:
relMSE (pbrt's, as `luz compare` reports it) over several seeds at each spp,
and the render time, both measured in this one run.

    pip install mitsuba==3.9.1 numpy OpenEXR
    python3 tools/sampler_peers.py cornell-area --luz target/release/luz

Each renderer is measured against its own high-spp reference (independent
sampler, other seeds): its error converges to its own image, and the two
agree to within the references' noise (printed as "references apart").
Times are each render alone, median over seeds: luz's from its summary line
(loading excluded), Mitsuba's from the render call with its kernels compiled
in a warm-up render at the same spp. The renderers take turns seed by seed,
so that a change in the machine's load falls on all of them alike.
`relMSE × s` is the error at equal time up to a constant while relMSE falls
as 1/spp: the lower, the better the sampler spends a second.
"""

import argparse
import os
import re
import statistics
import subprocess
import tempfile
import time

import drjit as dr
import Imath
import mitsuba as mi
import numpy as np
import OpenEXR

import mitsuba_peer

# Untimed pause after each Mitsuba render, while Dr.Jit's worker threads stop
# spinning: without it the next render shares the cores with them (the luz
# render that followed took 5 ms instead of 1 ms at 32x32, 4 spp).
SETTLE_SECONDS = 0.1

SCENE_FILES = {name: f"scenes/{name}.toml" for name in ["cornell-point", "cornell-area", "bunny"]}


def rel_mse(image, reference):
    return float(np.mean((image - reference) ** 2 / (reference**2 + 1e-2)))


def read_exr(path):
    """The R, G, B layers of luz's EXR (it also holds its sums and stderr)."""
    file = OpenEXR.InputFile(path)
    window = file.header()["dataWindow"]
    shape = (window.max.y - window.min.y + 1, window.max.x - window.min.x + 1)
    channels = file.channels("RGB", Imath.PixelType(Imath.PixelType.FLOAT))
    return np.stack([np.frombuffer(c, np.float32).reshape(shape) for c in channels], axis=-1)


class Mitsuba:
    def __init__(self, args, sampler):
        self.loaded = mi.load_dict(mitsuba_peer.scene(args.scene, args.assets, 1, args.resolution,
                                                      sampler=sampler))

    def prepare(self, spp):
        """A render untimed: a sampler's sample count can be part of the kernel."""
        self.render(spp, 0)

    def render(self, spp, seed):
        start = time.perf_counter()
        image = mi.render(self.loaded, seed=seed, spp=spp)
        pixels = np.array(image)  # Dr.Jit evaluates lazily: reading back waits for the render
        seconds = time.perf_counter() - start
        time.sleep(SETTLE_SECONDS)
        return pixels, seconds


class Luz:
    SUMMARY = re.compile(r"threads: ([0-9.]+) s,")

    def __init__(self, args, sampler):
        self.args, self.sampler = args, sampler
        self.out = tempfile.mkdtemp(prefix="luz-peers-")

    def prepare(self, spp):
        pass

    def render(self, spp, seed):
        a = self.args
        out = os.path.join(self.out, f"{self.sampler}-{spp}-{seed}.exr")
        command = [a.luz, "render", SCENE_FILES[a.scene], "--resolution", f"{a.resolution}x{a.resolution}",
                   "--spp", str(spp), "--seed", str(seed), "--sampler", self.sampler,
                   "--threads", str(a.threads), "--backend", a.backend, "-o", out]
        summary = subprocess.run(command, check=True, capture_output=True, text=True).stderr
        return read_exr(out), float(self.SUMMARY.search(summary).group(1))


def reference(renderer, args):
    """The mean of `reference_passes` independent renders: one render of 4096 spp
    would hold every sample's state in Mitsuba's wavefront at once."""
    spp = args.reference_spp // args.reference_passes
    renderer.prepare(spp)
    images = [renderer.render(spp, args.reference_seed + k)[0] for k in range(args.reference_passes)]
    return np.mean(images, axis=0)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("scene", choices=sorted(SCENE_FILES))
    parser.add_argument("--luz", default="target/release/luz")
    parser.add_argument("--backend", default="embree", choices=["embree", "rust"])
    parser.add_argument("--variant", default="llvm_ad_rgb")
    parser.add_argument("--mitsuba-samplers", default="independent,stratified,multijitter,ldsampler")
    parser.add_argument("--spp", default="4,16,64,256")
    parser.add_argument("--seeds", type=int, default=8, help="seeds 1..N per cell")
    parser.add_argument("--reference-spp", type=int, default=4096)
    parser.add_argument("--reference-passes", type=int, default=16)
    parser.add_argument("--reference-seed", type=int, default=1000)
    parser.add_argument("--resolution", type=int, default=128, help="image width and height")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--assets", default=os.environ.get("LUZ_ASSETS", "../shared/assets"))
    args = parser.parse_args()
    mi.set_variant(args.variant)
    dr.set_thread_count(args.threads)
    spps = [int(s) for s in args.spp.split(",")]
    renderers = [(f"luz {s}", Luz(args, s)) for s in ["sobol", "independent"]]
    renderers += [(f"Mitsuba {s}", Mitsuba(args, s)) for s in args.mitsuba_samplers.split(",")]
    references = {"luz": reference(renderers[1][1], args), "Mitsuba": reference(renderers[2][1], args)}
    print(f"{args.scene}, {args.resolution}x{args.resolution}, {args.threads} threads, luz {args.backend}, "
          f"Mitsuba {args.variant}; mean relMSE over seeds 1-{args.seeds} (median s per render)")
    print(f"references apart: relMSE {rel_mse(references['Mitsuba'], references['luz']):.3g}")
    errors, seconds = {}, {}
    for spp in spps:
        for _, renderer in renderers:
            renderer.prepare(spp)
        for seed in range(1, args.seeds + 1):
            for name, renderer in renderers:
                image, s = renderer.render(spp, seed)
                errors.setdefault((name, spp), []).append(rel_mse(image, references[name.split()[0]]))
                seconds.setdefault((name, spp), []).append(s)
    print("| sampler | " + " | ".join(f"{s} spp" for s in spps) + " | relMSE × s at " + f"{spps[-1]} spp |")
    print("|---" * (len(spps) + 2) + "|")
    mean = {key: statistics.mean(e) for key, e in errors.items()}
    median = {key: statistics.median(s) for key, s in seconds.items()}
    for name, _ in renderers:
        cells = [f"{mean[name, spp]:.3g} ({median[name, spp]:.3f} s)" for spp in spps]
        last = (name, spps[-1])
        print(f"| {name} | " + " | ".join(cells) + f" | {mean[last] * median[last]:.3g} |")
    print()
    print("luz sobol's error at equal time against each Mitsuba sampler: its relMSE ratio times the")
    print("median of the time ratios of the renders of one seed (their range in brackets)")
    print("| against | " + " | ".join(f"{s} spp" for s in spps) + " |")
    print("|---" * (len(spps) + 1) + "|")
    for name in (name for name, _ in renderers if name.startswith("Mitsuba")):
        cells = []
        for spp in spps:
            ratios = [a / b for a, b in zip(seconds["luz sobol", spp], seconds[name, spp])]
            error = mean["luz sobol", spp] / mean[name, spp]
            cells.append(f"{error * statistics.median(ratios):.2f}× ({min(ratios):.2f}–{max(ratios):.2f})")
        print(f"| {name} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
