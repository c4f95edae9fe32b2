"""Where the time of a frame goes, candela against Mitsuba 3, stage by stage, on one thread.

For each scene, both renderers render it to path depth 1 (camera rays and what they see), 2
(plus direct lighting and the first bounce's emission) and the scene's own depth, one thread
each, in the same run: candela's render time (its `--stats`, without loading), Mitsuba's
render call (warm, median of three). With `perf` installed, Mitsuba's render is sampled and
split between Embree (`libembree3`: its ray traversal) and the rest (its JIT-compiled kernel:
sampling, shading, film). The differences between depths give each stage's cost per sample.

Usage: python bench/stages.py CANDELA_BIN SCENE.xml [SCENE.xml ...] [--spp 64] [--res 512]
(run by scripts/compare-stages.sh, with the bench's virtual environment). A scene sets its path
depth through `<default name="max_depth" .../>` and its size through `res`, as the bench's do.
"""

import argparse, os, re, subprocess, sys, tempfile, time


def candela_time(binary, xml, depth, spp, res):
    out = os.path.join(tempfile.mkdtemp(), "c.pfm")
    cmd = [binary, "render", xml, "-o", out, "-d", f"res={res}", "--spp", str(spp),
           "--threads", "1", "--stats", "--quiet"]
    if depth is not None:
        cmd += ["--max-depth", str(depth)]
    times = []
    for _ in range(3):
        r = subprocess.run(cmd, check=True, capture_output=True, text=True)
        m = re.search(r"\(1 threads?\): ([0-9.]+) s", r.stderr)
        if not m:
            sys.exit(f"no render time in candela's --stats output:\n{r.stderr}")
        times.append(float(m.group(1)))
    return sorted(times)[1]


MITSUBA = r"""
import sys, time, os, mitsuba as mi, drjit as dr, numpy as np
mi.set_variant('llvm_ad_rgb')
dr.set_thread_count(1)
xml, spp, res, depth, flag = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4], sys.argv[5]
kw = dict(res=res, spp=spp)
if depth != 'scene':
    kw['max_depth'] = int(depth)
scene = mi.load_file(xml, **kw)
np.array(mi.render(scene, spp=spp, seed=7))
open(flag, 'w').write('warm')
ts = []
for s in range(3):
    t = time.perf_counter(); np.array(mi.render(scene, spp=spp, seed=s)); ts.append(time.perf_counter() - t)
print(sorted(ts)[1], flush=True)
"""


def mitsuba_time(python, xml, depth, spp, res, perf):
    d = tempfile.mkdtemp()
    flag, data = os.path.join(d, "warm"), os.path.join(d, "perf.data")
    p = subprocess.Popen([python, "-c", MITSUBA, xml, str(spp), str(res),
                          "scene" if depth is None else str(depth), flag],
                         stdout=subprocess.PIPE, text=True)
    rec = None
    while p.poll() is None and not os.path.exists(flag):
        time.sleep(0.05)
    if perf and p.poll() is None:
        rec = subprocess.Popen(["perf", "record", "-q", "-p", str(p.pid), "-o", data],
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    out, _ = p.communicate()
    if p.returncode != 0:
        sys.exit("Mitsuba failed")
    embree = None
    if rec is not None:
        rec.send_signal(2)
        rec.wait()
        rep = subprocess.run(["perf", "report", "-i", data, "--no-children", "--sort", "dso",
                              "--stdio"], capture_output=True, text=True).stdout
        shares = {}
        for line in rep.splitlines():
            m = re.match(r"\s*([0-9.]+)%\s+(\S.*?)\s*$", line)
            if m:
                shares[m.group(2)] = float(m.group(1))
        embree = sum(v for k, v in shares.items() if "embree" in k) / 100.0
    return float(out.split()[-1]), embree


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("candela")
    ap.add_argument("scenes", nargs="+")
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--res", type=int, default=512)
    a = ap.parse_args()
    perf = subprocess.run(["which", "perf"], capture_output=True).returncode == 0
    n = a.res * a.res * a.spp
    for xml in a.scenes:
        print(f"\n{os.path.basename(xml)}: {a.res}x{a.res}, {a.spp} spp, one thread "
              "(ns per sample; Mitsuba: render call, independent sampler as in the file)")
        print(f"{'stage':<16}{'candela':>10}{'Mitsuba':>10}{'ratio':>8}"
              f"{'Mitsuba Embree':>16}{'Mitsuba rest':>14}")
        prev = (0.0, 0.0, 0.0, 0.0)
        for depth, name in [(1, "depth 1"), (2, "1 -> 2"), (None, "2 -> scene's")]:
            c = candela_time(a.candela, xml, depth, a.spp, a.res)
            m, e = mitsuba_time(sys.executable, xml, depth, a.spp, a.res, perf)
            me, mr = (m * e, m * (1 - e)) if e is not None else (float("nan"),) * 2
            dc, dm, de, dr_ = (c - prev[0], m - prev[1], me - prev[2], mr - prev[3])
            ns = lambda s: s * 1e9 / n
            print(f"{name:<16}{ns(dc):>10.1f}{ns(dm):>10.1f}{dc / dm:>8.2f}"
                  f"{ns(de):>16.1f}{ns(dr_):>14.1f}")
            prev = (c, m, me, mr)
        print(f"{'whole frame':<16}{prev[0] * 1e9 / n:>10.1f}{prev[1] * 1e9 / n:>10.1f}"
              f"{prev[0] / prev[1]:>8.2f}{prev[2] * 1e9 / n:>16.1f}{prev[3] * 1e9 / n:>14.1f}")


if __name__ == "__main__":
    main()
