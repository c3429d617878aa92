"""Image and direction metrics against ground truth, and the scene regions they are reported over.

scikit-image (SSIM) and flip-evaluator (FLIP) are optional dependencies
(``pip install caustica[metrics]``), imported when first used.
"""
from .directions import angular_error, exact_exit_directions
from .images import psnr_linear, psnr_srgb, relmse
from .perceptual import flip, flip_error_map, flip_map, ssim, ssim_map
from .regions import REGIONS, caustic_region, compare_images, region_masks

__all__ = [
    "psnr_linear", "psnr_srgb", "relmse",
    "ssim", "ssim_map", "flip", "flip_error_map", "flip_map",
    "angular_error", "exact_exit_directions",
    "REGIONS", "region_masks", "caustic_region", "compare_images",
]
