"""Reference numbers for benches/imaging.rs: OpenCV (PyPI opencv-python-headless<5) AKAZE and KAZE on the
identical synthetic 1024² pair (the workspace's tests/fixtures/src/imaging.rs: SplitMix64 blobs, ±4σ stamps,
floor(x + 0.5) quantisation).

Run by hand: python3 -m venv /tmp/cv && /tmp/cv/bin/pip install "opencv-python-headless<5" &&
/tmp/cv/bin/python workflow/imaging/benches/opencv_akaze.py [--tsv PATH]
With --tsv it also writes one line per detector (name, ms 1 thread, ms all threads, keypoints A, keypoints B,
repeatability, matches, inliers, CPU ms 1 thread; tab-separated) for `OPENCV_RESULTS=PATH cargo bench -p plumbline-imaging`.
benches/compare_opencv.sh runs both interleaved.

With --match DIR it also times BFMatcher (NORM_HAMMING for AKAZE, NORM_L2 for KAZE; knnMatch k=2, and the
backward knnMatch k=1 of a mutual check) on the descriptors that `cargo bench -p plumbline-imaging --bench
imaging -- export-descriptors DIR` wrote, and adds a row per detector (match NAME, descriptors A, B, knnMatch
ms 1 thread, ms all threads, CPU ms 1 thread, knn + back ms 1 thread, ratio-0.8 mutual matches).
--no-detectors skips the detector rows.
"""
import argparse
import math
import time

import cv2
import numpy as np

M64 = (1 << 64) - 1


class SplitMix:
    def __init__(self, seed):
        self.s = seed

    def next(self):
        self.s = (self.s + 0x9E3779B97F4A7C15) & M64
        z = self.s
        z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & M64
        z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & M64
        return z ^ (z >> 31)

    def uniform(self, a, b):
        return a + (b - a) * (self.next() >> 11) / float(1 << 53)


def blobs(seed, n, size):
    rng = SplitMix(seed)
    out = []
    for _ in range(n):
        x, y, s, a = rng.uniform(0, size), rng.uniform(0, size), rng.uniform(1.5, 8.0), rng.uniform(40.0, 90.0)
        out.append((x, y, s, a if rng.next() & 1 else -a))
    return out


def truth(size):
    s, c, m = 0.8 * math.sin(0.2), 0.8 * math.cos(0.2), size / 2
    return np.array([[c, -s, m - c * m + s * m + 10.0], [s, c, m - s * m - c * m - 6.0], [0, 0, 1.0]])


def render(size, bl, t, scale, gain, background):
    acc = np.full((size, size), background, dtype=np.float64)
    for bx, by, bs, ba in bl:
        x, y = t[0, 0] * bx + t[0, 1] * by + t[0, 2], t[1, 0] * bx + t[1, 1] * by + t[1, 2]
        s, a = bs * scale, ba * gain
        c0, c1 = int(max(math.floor(x - 4 * s), 0)), int(min(math.ceil(x + 4 * s), size))
        r0, r1 = int(max(math.floor(y - 4 * s), 0)), int(min(math.ceil(y + 4 * s), size))
        if c1 <= c0 or r1 <= r0:
            continue
        cc, rr = np.meshgrid(np.arange(c0, c1) + 0.5, np.arange(r0, r1) + 0.5)
        acc[r0:r1, c0:c1] += a * np.exp(-((cc - x) ** 2 + (rr - y) ** 2) / (2 * s * s))
    return np.floor(np.clip(acc, 0, 255) + 0.5).astype(np.uint8)


def median_ms(f, runs=5, clock=time.perf_counter):
    t = []
    for _ in range(runs):
        s = clock()
        f()
        t.append((clock() - s) * 1e3)
    return sorted(t)[len(t) // 2]


def quality(ka, da, kb, db, t, size):
    pa = np.array([k.pt for k in ka]) + 0.5  # OpenCV pixel centres are integers; ours are +0.5
    pb = np.array([k.pt for k in kb]) + 0.5
    proj = (t[:2, :2] @ pa.T).T + t[:2, 2]
    inside = proj[(proj[:, 0] > 16) & (proj[:, 1] > 16) & (proj[:, 0] < size - 16) & (proj[:, 1] < size - 16)]
    hits = sum(1 for p in inside if np.min(np.hypot(pb[:, 0] - p[0], pb[:, 1] - p[1])) < 2.5)
    norm = cv2.NORM_HAMMING if da.dtype == np.uint8 else cv2.NORM_L2
    bf = cv2.BFMatcher(norm)
    knn = bf.knnMatch(da, db, k=2)
    back = {m[0].queryIdx: m[0].trainIdx for m in bf.knnMatch(db, da, k=1)}
    good = [m[0] for m in knn if len(m) == 2 and m[0].distance < 0.8 * m[1].distance and back.get(m[0].trainIdx) == m[0].queryIdx]
    src = np.float32([pa[m.queryIdx] for m in good])
    dst = np.float32([pb[m.trainIdx] for m in good])
    _, mask = cv2.estimateAffinePartial2D(src, dst, method=cv2.RANSAC, ransacReprojThreshold=2.5)
    return hits / max(len(inside), 1), int(mask.sum()) if mask is not None else 0, len(good)


def bf_matching(directory):
    """BFMatcher on the exported descriptors: one TSV row per detector."""
    rows = []
    print("| BFMatcher | descriptors A × B | knnMatch ms (1 thread) | ms (all cores) | CPU ms (1 thread) | knn + back ms (1 thread) | matches |")
    print("|---|---|---|---|---|---|---|")
    for name, suffix, dtype, norm in [("AKAZE", "u8", np.uint8, cv2.NORM_HAMMING), ("KAZE", "f32", "<f4", cv2.NORM_L2)]:
        da = np.fromfile(f"{directory}/{name.lower()}_a.{suffix}", dtype=dtype).reshape(-1, 64)
        db = np.fromfile(f"{directory}/{name.lower()}_b.{suffix}", dtype=dtype).reshape(-1, 64)
        if dtype != np.uint8:
            da, db = da.astype(np.float32), db.astype(np.float32)
        bf = cv2.BFMatcher(norm)
        cv2.setNumThreads(1)
        one = median_ms(lambda: bf.knnMatch(da, db, k=2))
        cpu = median_ms(lambda: bf.knnMatch(da, db, k=2), clock=time.process_time)
        both = median_ms(lambda: (bf.knnMatch(da, db, k=2), bf.knnMatch(db, da, k=1)))
        cv2.setNumThreads(-1)
        allc = median_ms(lambda: bf.knnMatch(da, db, k=2))
        knn = bf.knnMatch(da, db, k=2)
        back = {m[0].queryIdx: m[0].trainIdx for m in bf.knnMatch(db, da, k=1)}
        good = [m[0] for m in knn if len(m) == 2 and m[0].distance < 0.8 * m[1].distance and back.get(m[0].trainIdx) == m[0].queryIdx]
        print(f"| {name} | {len(da)} × {len(db)} | {one:.1f} | {allc:.1f} | {cpu:.1f} | {both:.1f} | {len(good)} |")
        rows.append(f"match {name}\t{len(da)}\t{len(db)}\t{one:.2f}\t{allc:.2f}\t{cpu:.2f}\t{both:.2f}\t{len(good)}\n")
    return rows


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--tsv", help="also write the rows, tab-separated, to this file")
    parser.add_argument("--match", metavar="DIR", help="also time BFMatcher on the descriptors exported to DIR")
    parser.add_argument("--no-detectors", action="store_true", help="skip the detector rows")
    args = parser.parse_args()
    rows = []
    print(f"opencv {cv2.__version__}")
    if args.match:
        rows += bf_matching(args.match)
    if args.no_detectors:
        if args.tsv:
            with open(args.tsv, "w") as out:
                out.writelines(rows)
        return
    size = 1024
    bl, t = blobs(42, 3000, size), truth(size)
    a = render(size, bl, np.eye(3), 1.0, 1.0, 128.0)
    b = render(size, bl, t, 0.8, 0.7, 0.7 * 128.0 + 25.0)
    print("| detector | ms (1 thread) | ms (all cores) | keypoints A / B | repeatability | matches | inliers |")
    print("|---|---|---|---|---|---|---|")
    for name, make in [("AKAZE", cv2.AKAZE_create), ("AKAZE upright", lambda: cv2.AKAZE_create(cv2.AKAZE_DESCRIPTOR_MLDB_UPRIGHT)), ("KAZE", cv2.KAZE_create)]:
        det = make()
        cv2.setNumThreads(1)
        one = median_ms(lambda: det.detectAndCompute(a, None))
        cpu = median_ms(lambda: det.detectAndCompute(a, None), clock=time.process_time)
        cv2.setNumThreads(-1)
        allc = median_ms(lambda: det.detectAndCompute(a, None))
        ka, da = det.detectAndCompute(a, None)
        kb, db = det.detectAndCompute(b, None)
        rep, inl, m = quality(ka, da, kb, db, t, size)
        print(f"| {name} | {one:.0f} | {allc:.0f} | {len(ka)} / {len(kb)} | {rep:.3f} | {m} | {inl} |")
        rows.append(f"{name}\t{one:.1f}\t{allc:.1f}\t{len(ka)}\t{len(kb)}\t{rep:.4f}\t{m}\t{inl}\t{cpu:.1f}\n")
    if args.tsv:
        with open(args.tsv, "w") as out:
            out.writelines(rows)


if __name__ == "__main__":
    main()
