"""Renders any Mitsuba XML scene with Mitsuba 3, and compares two renders
by 8x8 blocks, so that luz's import of other people's scenes can be checked
against Mitsuba itself (issue 14).

    python3 tools/mitsuba_xml.py render SCENE.xml -o mitsuba.exr [--spp N] [--variant V]
    python3 tools/mitsuba_xml.py compare luz.exr mitsuba.exr [--floor luz-seed2.exr]

`render` loads the file as it is (its includes spliced in, so that the
edits below reach them), except for what Mitsuba 3.9.1 itself
refuses in 0.5-format scenes: the `strictNormals`, `high_quality_edges`,
`extEta` properties and the film's `fileFormat`/`gamma` are dropped, and a
`sobol` sampler becomes `independent`, `lookAt` is spelled `lookat`, and
`--resolution WxH` replaces the film's width and height, and the
reconstruction filter becomes the one-pixel box luz uses. The edits happen in memory; the
scene's folder is added to Mitsuba's file resolver. It prints the render's
wall time (loading and JIT compilation excluded, after a warm-up render).

`compare` prints the ratio of the means (A / B) and the block error: the
RMS difference of the 8x8-block means of the luminance, relative to B's
mean. With `--floor C` (luz again with another seed) it also prints the
block error of A against C, luz's own noise floor, and the ratio of the two.
"""

import argparse
import os
import re
import time

import drjit as dr
import mitsuba as mi
import numpy as np

DROPPED = ["strictNormals", "high_quality_edges", "extEta", "fileFormat", "gamma"]


def edited(text, resolution):
    for name in DROPPED:
        text = re.sub(r'<[a-z]+ name="%s"[^>]*/>' % name, "", text)
    text = text.replace("<lookAt", "<lookat")
    # luz filters with a one-pixel box; so does the peer.
    text = re.sub(r'<rfilter[^>]*/>', '<rfilter type="box"/>', text)
    text = re.sub(r'<rfilter[^>]*>.*?</rfilter>', '<rfilter type="box"/>', text, flags=re.S)
    if resolution:
        w, h = resolution.split("x")
        text = re.sub(r'(<integer name="width" value=")[^"]*"', r'\g<1>%s"' % w, text)
        text = re.sub(r'(<integer name="height" value=")[^"]*"', r'\g<1>%s"' % h, text)
    return text.replace('<sampler type="sobol"', '<sampler type="independent"')


def spliced(text, folder, depth=0):
    """The scene text with every <include> replaced by the body of the
    file it names (found next to the including file, else in the scene's
    folder), so that the edits above reach a film or filter written in an
    included file, as in Mitsuba's material-preview scenes."""
    if depth > 16:
        raise SystemExit("mitsuba_xml.py: includes nest deeper than 16")

    def body(match):
        name = match.group(1)
        path = os.path.join(folder, name)
        with open(path) as f:
            inner = f.read()
        inner = re.sub(r"<\?xml[^>]*\?>", "", inner)
        inner = re.sub(r"^\s*<scene[^>]*>", "", inner)
        inner = re.sub(r"</scene>\s*$", "", inner)
        return spliced(inner, os.path.dirname(path), depth + 1)

    return re.sub(r'<include\s+filename="([^"]+)"\s*/>', body, text)


def render(args):
    mi.set_variant(args.variant)
    folder = os.path.dirname(os.path.abspath(args.scene))
    mi.file_resolver().append(folder)
    with open(args.scene) as f:
        text = spliced(f.read(), folder)
    scene = mi.load_string(edited(text, args.resolution))
    spp = args.spp or 0
    mi.render(scene, spp=min(spp or 4, 4), seed=args.seed + 1)
    start = time.perf_counter()
    image = mi.render(scene, spp=spp, seed=args.seed)
    dr.eval(image)
    dr.sync_thread()
    elapsed = time.perf_counter() - start
    mi.Bitmap(image).write(args.output)
    print(f"rendered in {elapsed:.2f} s: {args.output}")


def luminance(path):
    mi.set_variant("scalar_rgb")
    # luz's EXRs carry more layers (sums, standard errors): keep the root's.
    root = dict(mi.Bitmap(path).split())["<root>"]
    a = np.array(root.convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32))
    return 0.2126 * a[..., 0] + 0.7152 * a[..., 1] + 0.0722 * a[..., 2]


def blocks(y, size=8):
    h, w = (y.shape[0] // size) * size, (y.shape[1] // size) * size
    return y[:h, :w].reshape(h // size, size, w // size, size).mean(axis=(1, 3))


def block_error(a, b):
    return float(np.sqrt(np.mean((blocks(a) - blocks(b)) ** 2)) / max(b.mean(), 1e-12))


def compare(args):
    a, b = luminance(args.a), luminance(args.b)
    error = block_error(a, b)
    print(f"mean A / B = {a.mean() / b.mean():.4f} (A {a.mean():.5g}, B {b.mean():.5g}); block error {error:.4f}")
    if args.floor:
        floor = block_error(a, luminance(args.floor))
        print(f"noise floor (A against {args.floor}) {floor:.4f}; block error / floor = {error / floor:.2f}")


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True)
    r = sub.add_parser("render")
    r.add_argument("scene")
    r.add_argument("-o", "--output", required=True)
    r.add_argument("--spp", type=int, help="samples per pixel (default: the scene's)")
    r.add_argument("--seed", type=int, default=0)
    r.add_argument("--resolution", help="WxH in place of the film's")
    r.add_argument("--variant", default="llvm_ad_rgb")
    c = sub.add_parser("compare")
    c.add_argument("a")
    c.add_argument("b")
    c.add_argument("--floor")
    args = parser.parse_args()
    render(args) if args.command == "render" else compare(args)


if __name__ == "__main__":
    main()
