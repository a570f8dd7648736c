"""Egocentric vision: headless MuJoCo rendering of RGB, depth and segmentation."""
