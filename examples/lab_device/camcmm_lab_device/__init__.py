"""A lab's own device for camcmm: a motorised lift (z axis), simulated. See README.md."""
