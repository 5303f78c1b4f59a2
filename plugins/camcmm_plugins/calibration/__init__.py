"""Camera calibration plugins (issue #7; thesis ch. 2.3-2.4, 3.2.3, 3.2.4).

One topic a module: ``boards`` (board specs, detection), ``camera`` (single camera),
``stereo`` (stereo pair, rectification, epipolar errors), ``covariance`` (parameter
covariance from the calibration Jacobian), ``projection`` (mrcal-style projection
uncertainty map), ``triangulation`` (linear/optimal, N views, covariance), ``scale``
(scale factor against a laser interferometer), ``gauge`` (gauge block on a platen),
``synthetic`` (rendered board images with known truth); ``plugin`` holds the host's
entry points and ``cli_*`` the ``calibrate``, ``scale`` and ``gauge-block`` commands.
Calibration files are read and written by ``camcmm.api.read_calibration`` /
``write_calibration``.
"""
