#!/usr/bin/env python3
"""Solve an exported plumbline adjustment problem (pole CUPTs + DG random-walk chain) with GTSAM's
Levenberg-Marquardt, for `cargo bench -p plumbline-adjustment --bench gtsam` (which runs this script).

Setup (not needed by CI):  pip install gtsam   (tested with gtsam 4.3.0)
Usage: gtsam_compare.py problem.json solution.json
Writes {"nodes": [[dE, dN, dU, th_e, th_n, th_u], ...], "seconds": optimise wall time, "iterations": n}.
The model is the one of workflow/adjustment/src/model.rs (pole): h = (p + dp + Exp(dth)(obs - p))_xy,
residual h - cadastre with sigma per coordinate; variables are the 6-vector corrections of the nodes, with
a zero-mean prior and a random-walk BetweenFactor between consecutive nodes (diagonal sigmas).
"""
import json
import sys
import time

import numpy as np
import gtsam


def skew(v):
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def exp_so3(phi):
    theta = np.linalg.norm(phi)
    k = skew(phi)
    if theta < 1e-12:
        return np.eye(3) + k
    return np.eye(3) + np.sin(theta) / theta * k + (1 - np.cos(theta)) / theta**2 * k @ k


def left_jacobian(phi):
    theta = np.linalg.norm(phi)
    k = skew(phi)
    if theta < 1e-8:
        return np.eye(3) + 0.5 * k
    return np.eye(3) + (1 - np.cos(theta)) / theta**2 * k + (theta - np.sin(theta)) / theta**3 * k @ k


def pole_factor(pole, keys):
    weights = [w for (_, w) in pole["parts"]]
    p = np.array(pole["dg_position"])
    offset = np.array(pole["observed"]) - p
    cadastre = np.array(pole["cadastre"])

    def error(this, values, jacobians):
        delta = sum(w * values.atVector(k) for k, w in zip(this.keys(), weights))
        rotated = exp_so3(delta[3:]) @ offset
        h = p + delta[:3] + rotated
        if jacobians is not None:
            j = np.zeros((3, 6))
            j[:, :3] = np.eye(3)
            j[:, 3:] = -skew(rotated) @ left_jacobian(delta[3:])
            for i, w in enumerate(weights):
                jacobians[i] = w * j[:2, :]
        return h[:2] - cadastre

    noise = gtsam.noiseModel.Isotropic.Sigma(2, pole["sigma"])
    return gtsam.CustomFactor(noise, keys, error)


def main():
    problem = json.load(open(sys.argv[1]))
    graph = gtsam.NonlinearFactorGraph()
    initial = gtsam.Values()
    for k, node in enumerate(problem["nodes"]):
        initial.insert(k, np.zeros(6))
        graph.add(gtsam.PriorFactorVector(k, np.zeros(6), gtsam.noiseModel.Diagonal.Sigmas(np.array(node["prior_sigma"]))))
    means = problem.get("link_means") or [[0.0, 0.0, 0.0]] * len(problem["links"])
    for k, (sigma, mean) in enumerate(zip(problem["links"], means)):
        expected = np.concatenate([np.array(mean), np.zeros(3)])
        graph.add(gtsam.BetweenFactorVector(k, k + 1, expected, gtsam.noiseModel.Diagonal.Sigmas(np.array(sigma))))
    for pole in problem["poles"]:
        graph.add(pole_factor(pole, [k for (k, _) in pole["parts"]]))
    params = gtsam.LevenbergMarquardtParams()
    params.setRelativeErrorTol(1e-10)
    params.setAbsoluteErrorTol(1e-10)
    params.setMaxIterations(50)
    start = time.perf_counter()
    optimizer = gtsam.LevenbergMarquardtOptimizer(graph, initial, params)
    result = optimizer.optimize()
    seconds = time.perf_counter() - start
    nodes = [list(result.atVector(k)) for k in range(len(problem["nodes"]))]
    json.dump({"nodes": nodes, "seconds": seconds, "iterations": optimizer.iterations()}, open(sys.argv[2], "w"))


if __name__ == "__main__":
    main()
