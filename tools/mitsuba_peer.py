"""Renders the peer scenes of ../shared/SCENES.md with Mitsuba 3, so luz can
be compared with it pixel by pixel and second by second on the same machine.

    pip install mitsuba==3.9.1
    python3 tools/mitsuba_peer.py bunny --variant llvm_ad_rgb -o bunny-mitsuba.exr

The llvm variants need LLVM (Debian: libllvm19 or the newest available) and
DRJIT_LIBLLVM_PATH pointing at libLLVM*.so. Prints the render's wall time
(scene loading and JIT compilation excluded, as luz's summary excludes
loading; a first warm-up render compiles the kernels).
"""

import argparse
import os
import time

import drjit as dr
import mitsuba as mi

BOX = [  # (name, material, p0, p1, p2, p3)
    ("floor", "white", (-1, 0, 1), (1, 0, 1), (1, 0, -1), (-1, 0, -1)),
    ("ceiling", "white", (-1, 2, -1), (1, 2, -1), (1, 2, 1), (-1, 2, 1)),
    ("back", "white", (-1, 0, -1), (1, 0, -1), (1, 2, -1), (-1, 2, -1)),
    ("left", "red", (-1, 0, 1), (-1, 0, -1), (-1, 2, -1), (-1, 2, 1)),
    ("right", "green", (1, 0, -1), (1, 0, 1), (1, 2, 1), (1, 2, -1)),
]
SAMPLERS = ["independent", "stratified", "multijitter", "ldsampler", "orthogonal"]
LIGHT = ((-0.25, 1.98, -0.25), (0.25, 1.98, -0.25), (0.25, 1.98, 0.25), (-0.25, 1.98, 0.25))


def rectangle(p0, p1, p2, p3):
    """to_world mapping local (-1,-1),(1,-1),(1,1),(-1,1) onto p0..p3."""
    c = [(p0[i] + p2[i]) / 2 for i in range(3)]
    ex = [(p1[i] - p0[i]) / 2 for i in range(3)]
    ey = [(p3[i] - p0[i]) / 2 for i in range(3)]
    n = [ex[1] * ey[2] - ex[2] * ey[1], ex[2] * ey[0] - ex[0] * ey[2], ex[0] * ey[1] - ex[1] * ey[0]]
    ln = sum(v * v for v in n) ** 0.5
    n = [v / ln for v in n]
    m = [[ex[r], ey[r], n[r], c[r]] for r in range(3)] + [[0, 0, 0, 1]]
    return mi.ScalarTransform4f(m)


def diffuse(rgb):
    return {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": rgb}}}


def scene(name, assets, spp, resolution=512, mesh=None, sampler="independent"):
    s = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 5, "rr_depth": 5, "hide_emitters": False},
        "sensor": {
            "type": "perspective",
            "fov": 40,
            "fov_axis": "y",
            "to_world": mi.ScalarTransform4f().look_at(origin=[0, 1, 3.7], target=[0, 1, 0], up=[0, 1, 0]),
            "sampler": {"type": sampler, "sample_count": spp},
            "film": {"type": "hdrfilm", "width": resolution, "height": resolution, "pixel_format": "rgb",
                     "component_format": "float32", "rfilter": {"type": "box"}},
        },
    }
    colours = {"white": [0.8, 0.8, 0.8], "red": [0.8, 0.1, 0.1], "green": [0.1, 0.8, 0.1]}
    for quad, material, *corners in BOX:
        s[quad] = {"type": "rectangle", "to_world": rectangle(*corners), "bsdf": diffuse(colours[material])}
    if name == "cornell-point":
        s["light"] = {"type": "point", "position": [0, 1.6, 0], "intensity": {"type": "rgb", "value": [3, 3, 3]}}
    else:
        s["light"] = {"type": "rectangle", "to_world": rectangle(*LIGHT), "bsdf": diffuse([0, 0, 0]),
                      "emitter": {"type": "area", "radiance": {"type": "rgb", "value": [20, 20, 20]}}}
    if name == "bunny":
        s["bunny"] = {
            "type": "ply",
            "filename": mesh or os.path.join(assets, "stanford/bunny/bun_zipper.ply"),
            "face_normals": True,
            "to_world": mi.ScalarTransform4f().scale(7.0).translate([0.0168404, -0.0329874, 0.00153695]),
            "bsdf": diffuse(colours["white"]),
        }
    else:
        s["diffuse_sphere"] = {"type": "sphere", "center": [-0.45, 0.35, -0.3], "radius": 0.35,
                               "bsdf": diffuse(colours["white"])}
        s["glass_sphere"] = {"type": "sphere", "center": [0.45, 0.35, 0.3], "radius": 0.35,
                             "bsdf": {"type": "dielectric", "int_ior": 1.5, "ext_ior": 1.0}}
    return s


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("scene", choices=["cornell-point", "cornell-area", "bunny"])
    parser.add_argument("--variant", default="llvm_ad_rgb")
    parser.add_argument("--sampler", default="independent", choices=SAMPLERS)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--spp", type=int, default=64)
    parser.add_argument("--assets", default=os.environ.get("LUZ_ASSETS", "../shared/assets"))
    parser.add_argument("--resolution", type=int, default=512, help="image width and height")
    parser.add_argument("--mesh", help="the bunny scene's mesh file (default: the Stanford bunny)")
    parser.add_argument("--threads", type=int, help="Dr.Jit worker threads (default: all cores)")
    parser.add_argument("--whole", action="store_true",
                        help="no warm-up render: for timing the whole process from outside")
    parser.add_argument("-o", "--output")
    args = parser.parse_args()
    mi.set_variant(args.variant)
    if args.threads:
        dr.set_thread_count(args.threads)
    loaded = mi.load_dict(scene(args.scene, args.assets, args.spp, args.resolution, args.mesh, args.sampler))
    if not args.whole:
        mi.render(loaded, spp=1)  # warm-up: JIT compilation
    start = time.perf_counter()
    # spp given again: the warm-up's spp=1 sticks to the sampler otherwise.
    image = mi.render(loaded, seed=args.seed, spp=args.spp)
    # Dr.Jit evaluates lazily: reading a value back waits for the render.
    float(dr.sum(image.array)[0])
    elapsed = time.perf_counter() - start
    print(f"{args.scene} {args.variant} {args.sampler} {args.spp} spp: {elapsed:.3f} s")
    if args.output:
        mi.util.write_bitmap(args.output, image)


if __name__ == "__main__":
    main()
