"""LAB-1 length check: a made-up acceptance test written as a camcmm standard plugin,
using only :mod:`camcmm.api` (see README.md). The manifest is read without importing
anything here."""
