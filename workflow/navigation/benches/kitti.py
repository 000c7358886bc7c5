#!/usr/bin/env python3
"""Real-data benchmark of `plumbline navigate` against GTSAM on KITTI (never part of CI).

Data: KITTI raw 2011_10_03_drive_0027 (odometry sequence 00) as GTSAM ships it in its PyPI wheel: 100 Hz OXTS
IMU (`KittiEquivBiasedImu.txt`, axes x forward, y left, z up) and 1 Hz positions (`KittiGps_converted.txt`,
a local east-north-up frame). The positions are the OXTS solution itself, so they serve as the clean
reference: faults are injected into a copy and every method is scored against the clean fixes.

    python3 workflow/navigation/benches/kitti.py [--data DIR] [--plumbline BIN] [--seed N] [--work DIR]
        [--navigate-args '--imu-model industrial']

Without --data the script downloads the wheel (`pip download --no-deps gtsam==4.3.0`) into the work
directory and takes the three files from it. GTSAM's ImuFactor + GPSFactor (iSAM2) runs when `import gtsam`
works (`pip install gtsam==4.3.0`); otherwise its rows are left out. The binary defaults to
target/release/plumbline (build it with `cargo build --release -p plumbline-cli`).

Fault sets (seeded): clean; multipath (steps of 2-5 m for 10-30 s); outliers (isolated 10 m); outages of
60 s at several placements, one over the IMU's filled dropouts at 236 and 279 s after the first fix; and all of
them together. Printed per set and method: 2D RMSE and max against the clean fixes, overall and per fault
class, the share of clean fixes the filter did not use, and the run time; for plumbline, the share of the
used fixes its local innovation test flags and the fixes' scatter against the σ given (east/north/up).
"""

import argparse
import csv
import json
import math
import os
import random
import subprocess
import sys
import time
import zipfile

WHEEL = "gtsam==4.3.0"
FILES = ("KittiEquivBiasedImu.txt", "KittiGps_converted.txt")
# The converted frame is local; these offsets make it look like projected coordinates (UTM-sized numbers).
OFFSET = (500_000.0, 5_000_000.0, 100.0)
# Geodetic latitude of the drive (Karlsruhe), for the WGS 84 mechanisation.
LATITUDE_DEG = 48.98
# σ of the fixes as given to both methods: east, north, up (m).
FIX_STD = (0.05, 0.05, 0.1)
OUTAGE_S = 60.0


def fetch(work):
    """The directory holding the two KITTI files, downloading GTSAM's wheel when needed."""
    data = os.path.join(work, "data")
    if all(os.path.exists(os.path.join(data, f)) for f in FILES):
        return data
    wheels = os.path.join(work, "wheel")
    os.makedirs(wheels, exist_ok=True)
    if not any(n.endswith(".whl") for n in os.listdir(wheels)):
        subprocess.run([sys.executable, "-m", "pip", "download", "--no-deps", "-q", WHEEL, "-d", wheels], check=True)
    wheel = next(os.path.join(wheels, n) for n in os.listdir(wheels) if n.endswith(".whl"))
    os.makedirs(data, exist_ok=True)
    with zipfile.ZipFile(wheel) as z:
        for f in FILES:
            with open(os.path.join(data, f), "wb") as out:
                out.write(z.read("gtsam/Data/" + f))
    return data


def read_kitti(data):
    """IMU rows (time, dt, accel FLU, gyro FLU) and fixes (time, e, n, u) as floats."""
    imu = []
    with open(os.path.join(data, FILES[0])) as f:
        next(f)
        for line in f:
            v = [float(x) for x in line.split()]
            if len(v) == 8:
                imu.append(v)
    fixes = []
    with open(os.path.join(data, FILES[1])) as f:
        next(f)
        for line in f:
            v = [float(x) for x in line.split(",")]
            if len(v) == 4:
                fixes.append(v)
    return imu, fixes


def write_imu(imu, path):
    """`navigate`'s IMU file: increments over [t − dt, t] in body x forward, y right, z down. The file's first
    two rows carry gaps as their dt (46534 s, then 1.9 s) and are dropped."""
    with open(path, "w") as f:
        f.write("time_s,dt_s,dtheta_x_rad,dtheta_y_rad,dtheta_z_rad,dv_x_mps,dv_y_mps,dv_z_mps\n")
        for t, dt, ax, ay, az, gx, gy, gz in imu[first_regular(imu):]:
            f.write(f"{t!r},{dt!r},{gx * dt!r},{-gy * dt!r},{-gz * dt!r},{ax * dt!r},{-ay * dt!r},{-az * dt!r}\n")


def first_regular(imu):
    """Index of the first IMU row with an interval of the recording's rate (under 0.1 s)."""
    return next(i for i, row in enumerate(imu) if row[1] < 0.1)


def write_fixes(fixes, path):
    with open(path, "w") as f:
        f.write("time_s,easting_m,northing_m,height_m,std_east_m,std_north_m,std_height_m\n")
        for t, e, n, u in fixes:
            f.write(f"{t!r},{e + OFFSET[0]!r},{n + OFFSET[1]!r},{u + OFFSET[2]!r},{FIX_STD[0]},{FIX_STD[1]},{FIX_STD[2]}\n")


def fault_sets(fixes, seed):
    """{name: (fixes, {fix index: fault class})}: the faulted copies and which fixes each fault touched
    (an outage's missing fixes are classed `outage`)."""
    rng = random.Random(seed)
    t0 = fixes[0][0]
    n = len(fixes)
    sets = {"clean": (list(fixes), {})}

    def multipath(faulted, classes):
        for _ in range(6):
            start = rng.randrange(20, n - 40)
            length = rng.randint(10, 30)
            size = rng.uniform(2.0, 5.0)
            angle = rng.uniform(0, 2 * math.pi)
            for i in range(start, min(n, start + length)):
                t, e, nn, u = faulted[i]
                faulted[i] = (t, e + size * math.cos(angle), nn + size * math.sin(angle), u + 0.5 * size)
                classes[i] = "multipath"

    def outliers(faulted, classes):
        for i in rng.sample(range(10, n - 10), 12):
            if i in classes:
                continue
            t, e, nn, u = faulted[i]
            angle = rng.uniform(0, 2 * math.pi)
            faulted[i] = (t, e + 10.0 * math.cos(angle), nn + 10.0 * math.sin(angle), u)
            classes[i] = "outlier"

    def outage(at, classes):
        for i, f in enumerate(fixes):
            if at <= f[0] - t0 < at + OUTAGE_S:
                classes[i] = "outage"

    f, c = list(fixes), {}
    multipath(f, c)
    sets["multipath"] = (f, c)
    f, c = list(fixes), {}
    outliers(f, c)
    sets["outliers"] = (f, c)
    for at in (40.0, 230.0, 350.0):
        c = {}
        outage(at, c)
        sets[f"outage@{at:.0f}s"] = (list(fixes), c)
    f, c = list(fixes), {}
    multipath(f, c)
    outliers(f, c)
    outage(230.0, c)
    sets["all"] = (f, c)
    return sets


def kept(fixes, classes):
    return [f for i, f in enumerate(fixes) if classes.get(i) != "outage"]


def run_plumbline(binary, imu_csv, gnss_csv, out, extra=()):
    started = time.time()
    r = subprocess.run(
        [binary, "navigate", "--gnss", gnss_csv, "--imu", imu_csv, "--latitude", str(LATITUDE_DEG), "--out", out, *extra],
        capture_output=True,
        text=True,
    )
    elapsed = time.time() - started
    if r.returncode != 0:
        return None, elapsed, f"exit {r.returncode}: {r.stderr.strip().splitlines()[-1:]}"
    rows = []
    with open(os.path.join(out, "trajectory.csv")) as f:
        for row in csv.DictReader(f):
            rows.append((float(row["time[s]"]), float(row["easting[m]"]) - OFFSET[0], float(row["northing[m]"]) - OFFSET[1]))
    with open(os.path.join(out, "summary.json")) as f:
        summary = json.load(f)
    return (rows, summary), elapsed, ""


def consistency_note(summary):
    """The local test's flagged share of the fixes used and the fixes' scatter against their stated σ."""
    flagged = summary.get("consistency", {}).get("local_flagged_share")
    noise = summary.get("fix_noise") or {}
    parts = []
    if flagged is not None:
        parts.append(f"local test flags {100 * flagged:.1f} %")
    if noise.get("factor"):
        parts.append("scatter × " + "/".join(f"{k ** 0.5:.2f}" for k in noise["factor"]) + " the stated σ")
    return "; ".join(parts)


def interpolate(rows, t):
    lo, hi = 0, len(rows) - 1
    if t < rows[0][0] or t > rows[-1][0]:
        return None
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if rows[mid][0] <= t:
            lo = mid
        else:
            hi = mid
    a, b = rows[lo], rows[hi]
    w = 0.0 if b[0] == a[0] else (t - a[0]) / (b[0] - a[0])
    return a[1] + w * (b[1] - a[1]), a[2] + w * (b[2] - a[2])


def run_gtsam(imu, fixes, classes, faulted):
    """GTSAM's ImuFactor + GPSFactor with iSAM2, as in its IMUKittiExampleGPS.py but with every fix kept and
    the fixes' σ; returns positions at the clean fix epochs."""
    try:
        import gtsam
        import numpy as np
        from gtsam.symbol_shorthand import B, V, X
    except ImportError:
        return None, 0.0, "gtsam not installed"
    started = time.time()
    g = 9.8
    params = gtsam.PreintegrationParams.MakeSharedU(g)
    # GTSAM's KITTI metadata: accelerometer σ 0.01, gyroscope σ 1.75e-4, bias random walks 1.67e-4 / 2.91e-6.
    params.setAccelerometerCovariance(np.eye(3) * 0.01**2)
    params.setGyroscopeCovariance(np.eye(3) * 1.75e-4**2)
    params.setIntegrationCovariance(np.eye(3) * 1e-8)
    present = {i: faulted[i] for i in range(len(fixes)) if classes.get(i) != "outage"}
    gps_noise = gtsam.noiseModel.Diagonal.Sigmas(np.array(FIX_STD))
    isam = gtsam.ISAM2(gtsam.ISAM2Params())
    j = first_regular(imu)
    while j < len(imu) and imu[j][0] <= fixes[0][0]:
        j += 1
    p0 = gtsam.Point3(*fixes[0][1:])
    # Heading from the first two fixes, level.
    heading = math.atan2(fixes[1][2] - fixes[0][2], fixes[1][1] - fixes[0][1])
    pose = gtsam.Pose3(gtsam.Rot3.Yaw(heading), p0)
    vel = np.array([(fixes[1][1] - fixes[0][1]) / (fixes[1][0] - fixes[0][0]),
                    (fixes[1][2] - fixes[0][2]) / (fixes[1][0] - fixes[0][0]), 0.0])
    bias = gtsam.imuBias.ConstantBias()
    graph, values = gtsam.NonlinearFactorGraph(), gtsam.Values()
    graph.add(gtsam.PriorFactorPose3(X(0), pose, gtsam.noiseModel.Diagonal.Sigmas(np.array([0.05, 0.05, 0.5, 0.5, 0.5, 0.5]))))
    graph.add(gtsam.PriorFactorVector(V(0), vel, gtsam.noiseModel.Isotropic.Sigma(3, 1.0)))
    graph.add(gtsam.PriorFactorConstantBias(B(0), bias, gtsam.noiseModel.Diagonal.Sigmas(np.array([0.1] * 3 + [5e-5] * 3))))
    if 0 in present:
        graph.add(gtsam.GPSFactor(X(0), gtsam.Point3(*present[0][1:]), gps_noise))
    values.insert(X(0), pose)
    values.insert(V(0), vel)
    values.insert(B(0), bias)
    isam.update(graph, values)
    state = gtsam.NavState(pose, vel)
    for i in range(1, len(fixes)):
        pim = gtsam.PreintegratedImuMeasurements(params, bias)
        count = 0
        while j < len(imu) and imu[j][0] <= fixes[i][0]:
            t, dt, ax, ay, az, gx, gy, gz = imu[j]
            if dt < 0.5:
                pim.integrateMeasurement(np.array([ax, ay, az]), np.array([gx, gy, gz]), dt)
                count += 1
            j += 1
        graph, values = gtsam.NonlinearFactorGraph(), gtsam.Values()
        graph.add(gtsam.ImuFactor(X(i - 1), V(i - 1), X(i), V(i), B(i - 1), pim))
        sb = math.sqrt(max(count, 1))
        graph.add(gtsam.BetweenFactorConstantBias(B(i - 1), B(i), gtsam.imuBias.ConstantBias(),
                                                  gtsam.noiseModel.Diagonal.Sigmas(np.array([sb * 1.67e-4] * 3 + [sb * 2.91e-6] * 3))))
        if i in present:
            graph.add(gtsam.GPSFactor(X(i), gtsam.Point3(*present[i][1:]), gps_noise))
        predicted = pim.predict(state, bias)
        values.insert(X(i), predicted.pose())
        values.insert(V(i), predicted.velocity())
        values.insert(B(i), bias)
        isam.update(graph, values)
        est = isam.calculateEstimate()
        state = gtsam.NavState(est.atPose3(X(i)), est.atVector(V(i)))
        bias = est.atConstantBias(B(i))
    est = isam.calculateEstimate()
    rows = [(fixes[i][0], est.atPose3(X(i)).x(), est.atPose3(X(i)).y()) for i in range(len(fixes))]
    return rows, time.time() - started, ""


def score(rows, fixes, classes):
    """2D errors against the clean fixes: overall and per class."""
    by = {"all": []}
    for i, (t, e, n, _) in enumerate(fixes):
        p = interpolate(rows, t)
        if p is None:
            continue
        err = math.hypot(p[0] - e, p[1] - n)
        by["all"].append(err)
        by.setdefault(classes.get(i, "clean"), []).append(err)
    return {k: (math.sqrt(sum(x * x for x in v) / len(v)), max(v)) for k, v in by.items() if v}


def flagged_share(summary, classes, total):
    clean = [i for i in range(total) if i not in classes]
    # The summary numbers the fixes of the file navigate read, which lacks an outage's fixes.
    written = [i for i in range(total) if classes.get(i) != "outage"]
    acted = {written[a["fix"]] for a in summary.get("actions", []) if a["decision"] != "used"}
    return sum(1 for i in clean if i in acted) / max(len(clean), 1)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", help="directory with the two KITTI files (default: download the wheel)")
    ap.add_argument("--plumbline", default=os.path.join("target", "release", "plumbline"))
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--work", default=os.path.join("target", "kitti-bench"))
    ap.add_argument("--navigate-args", default="", help="more options for `plumbline navigate`, e.g. '--imu-model industrial'")
    args = ap.parse_args()
    os.makedirs(args.work, exist_ok=True)
    data = args.data or fetch(args.work)
    imu, fixes = read_kitti(data)
    fixes = [f for f in fixes if f[0] >= imu[first_regular(imu)][0]]
    imu_csv = os.path.join(args.work, "imu.csv")
    write_imu(imu, imu_csv)
    print(f"KITTI 2011_10_03_drive_0027: {len(imu)} IMU rows, {len(fixes)} fixes over {fixes[-1][0] - fixes[0][0]:.0f} s; seed {args.seed}; navigate --latitude {LATITUDE_DEG} {args.navigate_args}")
    print("| set | method | 2D RMSE m | max m | per class RMSE / max m | clean fixes not used | run s | note |")
    print("|---|---|---|---|---|---|---|---|")
    for name, (faulted, classes) in fault_sets(fixes, args.seed).items():
        gnss_csv = os.path.join(args.work, f"gnss-{name}.csv")
        write_fixes(kept(faulted, classes), gnss_csv)
        out = os.path.join(args.work, f"out-{name}")
        result, elapsed, note = run_plumbline(args.plumbline, imu_csv, gnss_csv, out, args.navigate_args.split())
        if result:
            note = consistency_note(result[1])
        rows = [("plumbline navigate", result[0] if result else None, elapsed, note,
                 f"{100 * flagged_share(result[1], classes, len(fixes)):.1f} %" if result else "")]
        g_rows, g_elapsed, g_note = run_gtsam(imu, fixes, classes, faulted)
        if g_note != "gtsam not installed":
            rows.append(("GTSAM ImuFactor+GPSFactor", g_rows, g_elapsed, g_note, "—"))
        for method, traj, secs, why, share in rows:
            if traj is None:
                print(f"| {name} | {method} | — | — | — | {share} | {secs:.1f} | {why} |")
                continue
            s = score(traj, fixes, classes)
            per = ", ".join(f"{k} {v[0]:.2f}/{v[1]:.2f}" for k, v in s.items() if k != "all")
            print(f"| {name} | {method} | {s['all'][0]:.3f} | {s['all'][1]:.2f} | {per} | {share} | {secs:.1f} | {why} |")
        sys.stdout.flush()


if __name__ == "__main__":
    main()
