"""Memory of a progressive render against its pass count: the peak resident set of a render of
P passes, each in a fresh process, side by side.

A render keeps one pass's photons, index, gather and GL textures at a time, and a film of
(h, w, 3) float64 sums; its peak should not grow with the passes.

usage: python tools/pass_memory.py [--scene scenes/ring.toml] [--photons 1000000]
                                   [--passes 2,100] [--size 512]
"""

import argparse
import json
import subprocess
import sys

CHILD = """
import json, resource, sys, time
import blockhash
from blockhash.frame.progressive import Renderer
scene = blockhash.load_scene(sys.argv[1]).with_size(int(sys.argv[2]), int(sys.argv[2]))
r = Renderer(scene, photons=int(sys.argv[3]))
t = time.perf_counter()
while r.passes < int(sys.argv[4]):
    r.step()
print(json.dumps({"passes": r.passes, "seconds": time.perf_counter() - t,
                  "peak_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                  "emitted": r.emitted, "stored": r.stored}))
"""


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scene", default="scenes/ring.toml")
    p.add_argument("--photons", type=int, default=1_000_000)
    p.add_argument("--passes", default="2,100")
    p.add_argument("--size", type=int, default=512)
    args = p.parse_args(argv)
    rows = []
    for n in (int(x) for x in args.passes.split(",")):
        out = subprocess.run([sys.executable, "-c", CHILD, args.scene, str(args.size),
                              str(args.photons), str(n)], capture_output=True, text=True, check=True)
        rows.append(json.loads(out.stdout.strip().splitlines()[-1]))
        print(json.dumps(rows[-1]), flush=True)
    base = rows[0]["peak_mib"]
    print(f"| passes | photons per pass | peak RSS (MiB) | against {rows[0]['passes']} passes | "
          "s per pass |\n| --- | --- | --- | --- | --- |")
    for r in rows:
        print(f"| {r['passes']} | {args.photons:,} | {r['peak_mib']:.0f} | {r['peak_mib'] / base:.3f} | "
              f"{r['seconds'] / r['passes']:.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
