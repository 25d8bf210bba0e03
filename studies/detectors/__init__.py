"""Detectors that run outside pfm-mpm: the library baseline (scikit-image), same contract as
``pfm-mpm detect`` (see skimage_detector.py)."""
