#!/usr/bin/env python3
"""Efficiency of candela against Mitsuba 3 without a reference image: from the spread of renders
made with different seeds.

An unbiased renderer's error at equal spp is its variance, and the variance of a pixel can be
estimated from N renders that differ only in their seed (the sample variance over the N values,
averaged over the pixels; values clamped at 50 as in ../shared/bench/efficiency.py). So scenes
without a high-spp reference (bench/extra/: the variants of the four kinds) can still be
compared: efficiency = 1 / (time x variance), relative to Mitsuba's best sampler, all renders in
the same run. Mitsuba's time is its render call (warm JIT, as efficiency.py takes it); candela's
the whole process. Each renderer's time is the median of its N renders.

Use N >= 4: the variance of scenes with bright, rare paths (fireflies) is itself noisy, and two
renders can be 20 % off (the two halves of the seeds are printed as a check).

Usage: python seed-variance.py CANDELA_BINARY SCENE.xml ... [--seeds N] [--spp 64] [--res 512]
       [--mi-samplers multijitter ldsampler]
Needs Mitsuba 3 and numpy in the running Python (scripts/compare-variants.sh runs it in the
bench virtual environment).
"""
import argparse, os, re, statistics, subprocess, sys, tempfile, time

os.environ.setdefault("DRJIT_LIBLLVM_PATH", "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1")


def read_pfm(path):
    import numpy as np
    with open(path, "rb") as f:
        data = f.read()
    magic, size, scale, rest = data.split(b"\n", 3)
    w, h = map(int, size.split())
    dt = "<f4" if float(scale) < 0 else ">f4"
    return np.frombuffer(rest[: w * h * 12], dtype=dt).reshape(h, w, 3)[::-1].astype("f8")


def variance(images):
    """Mean over pixels of the sample variance over the images, and the same for each half."""
    import numpy as np
    a = np.minimum(np.stack(images), 50.0)
    h = len(images) // 2
    v = lambda x: float(x.var(axis=0, ddof=1).mean())
    return v(a), v(a[:h]), v(a[h:])


def mitsuba(scene_xml, sampler, spp, res, seeds):
    import mitsuba as mi, numpy as np
    mi.set_variant("llvm_ad_rgb")
    text = re.sub(r'<sampler type="[a-z_]+">', f'<sampler type="{sampler}">', open(scene_xml).read())
    with tempfile.NamedTemporaryFile("w", suffix=".xml", dir=os.path.dirname(scene_xml),
                                     delete=False) as f:
        f.write(text)
        tmp = f.name
    try:
        scene = mi.load_file(tmp, res=res, spp=spp)
    finally:
        os.unlink(tmp)
    np.array(mi.render(scene, spp=spp, seed=10_000))  # warm-up (JIT)
    times, images = [], []
    for s in seeds:
        t = time.perf_counter()
        images.append(np.array(mi.render(scene, spp=spp, seed=s))[:, :, :3].astype("f8"))
        times.append(time.perf_counter() - t)
    return statistics.median(times), images


def candela(binary, scene_xml, spp, res, seeds):
    out = tempfile.mkdtemp()
    times, images = [], []
    for s in seeds:
        pfm = os.path.join(out, f"{s}.pfm")
        cmd = [binary, "render", scene_xml, "-o", pfm, "-d", f"res={res}", "--spp", str(spp),
               "--quiet", "--seed", str(s)]
        t = time.perf_counter()
        subprocess.run(cmd, check=True, capture_output=True)
        times.append(time.perf_counter() - t)
        images.append(read_pfm(pfm))
    return statistics.median(times), images


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("candela")
    ap.add_argument("scenes", nargs="+")
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--res", type=int, default=512)
    ap.add_argument("--mi-samplers", nargs="+", default=["multijitter", "ldsampler"])
    args = ap.parse_args()
    if args.seeds < 2:
        sys.exit("--seeds: at least 2 renders are needed for a variance")
    seeds = list(range(args.seeds))
    print(f"{args.res}x{args.res}, {args.spp} spp, {args.seeds} seeds; RMSE = sqrt(variance) "
          "(halves of the seeds in brackets)")
    print(f"{'scene':32} {'Mitsuba best':>30} {'candela':>30} {'speed':>6} {'eff.':>6}")
    for xml in args.scenes:
        xml = os.path.abspath(xml)
        best = None
        for smp in args.mi_samplers:
            t, imgs = mitsuba(xml, smp, args.spp, args.res, seeds)
            v = variance(imgs)
            if best is None or t * v[0] < best[1] * best[2][0]:
                best = (smp, t, v)
        t, imgs = candela(args.candela, xml, args.spp, args.res, seeds)
        v = variance(imgs)
        smp, tm, vm = best
        fmt = lambda t, v: f"{t:5.2f} s {v[0] ** .5:.5f} ({v[1] ** .5:.4f} {v[2] ** .5:.4f})"
        print(f"{os.path.basename(xml):32} {smp[:5]:>5} {fmt(tm, vm)} {fmt(t, v)} "
              f"{tm / t:6.2f} {tm * vm[0] / (t * v[0]):6.2f}", flush=True)


if __name__ == "__main__":
    main()
