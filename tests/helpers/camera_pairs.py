"""A stereo pair of cameras as plain numbers, written as OpenCV YAML or camcmm JSON with no camcmm
check in between (for the tests of what a calibration reader refuses)."""

from __future__ import annotations

import json

import cv2
import numpy as np

K1 = np.array([[800.0, 0, 320], [0, 800.0, 240], [0, 0, 1]])
K2 = np.array([[810.0, 0, 330], [0, 805.0, 236], [0, 0, 1]])
R2 = cv2.Rodrigues(np.array([0.01, -0.2, 0.003]))[0]
T2 = np.array([-150.0, 1.5, 12.0])


def _pair(**change):
    """Two cameras as plain numbers; ``change`` overrides fields of camera 1 (``k1``,
    ``d1``, ``size1``) or 2 (``k2``, ``d2``, ``r``, ``t``, ``size2``)."""
    v = {
        "k1": K1.copy(),
        "d1": np.array([-0.1, 0.05, 0, 0, 0.01]),
        "size1": [640, 480],
        "k2": K2.copy(),
        "d2": np.zeros(5),
        "r": R2.copy(),
        "t": T2.copy(),
        "size2": [640, 480],
    }
    v.update(change)
    return v


def _write_yaml(path, v):
    """An OpenCV stereo_calib-style file written by OpenCV itself (no camcmm check)."""
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    fs.write("M1", np.asarray(v["k1"], float))
    fs.write("D1", np.atleast_2d(np.asarray(v["d1"], float)))
    fs.write("image_size1", np.array([v["size1"]], np.float64))
    fs.write("M2", np.asarray(v["k2"], float))
    fs.write("D2", np.atleast_2d(np.asarray(v["d2"], float)))
    fs.write("image_size2", np.array([v["size2"]], np.float64))
    fs.write("R", np.asarray(v["r"], float))
    fs.write("T", np.asarray(v["t"], float).reshape(3, 1))
    fs.release()


def _write_json(path, v):
    def cam(k, d, r, t, size, name):
        return {
            "name": name,
            "camera_matrix": np.asarray(k, float).tolist(),
            "dist_coeffs": np.asarray(d).tolist(),
            "rotation": np.asarray(r, float).tolist(),
            "translation": np.asarray(t, float).tolist(),
            "image_size": list(size),
        }

    doc = {
        "format": "camcmm-calibration",
        "version": 1,
        "unit": "mm",
        "cameras": [
            cam(v["k1"], v["d1"], np.eye(3), np.zeros(3), v["size1"], "left"),
            cam(v["k2"], v["d2"], v["r"], v["t"], v["size2"], "right"),
        ],
    }
    path.write_text(json.dumps(doc))  # NaN/Infinity as Python's json writes them


def _with(k, i, j, value):
    k = np.array(k, float)
    k[i, j] = value
    return k
