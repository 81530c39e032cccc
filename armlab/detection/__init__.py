"""Block detection in RGB-D: height map from depth, arm and board masks, flat top faces, colour, size, yaw, world
position. Units: mm and rad in the world (board) frame; images RGB uint8, depth float mm.

Modules by job: types (Block, DetectionSettings), heightmap, masks, segment (flat faces), box_atlas (many small
boxes through one OpenCV call, for segment), colour_region (a face's pixels by colour, white balance), edges (square
fit, sub-pixel sides and yaw), stacks (stack arithmetic), color (the colour model), color_labels (labelled frames for
its fit), detect (the pipeline), draw."""

from armlab.detection.color import (
    ColorModel,
    color_features,
    default_color_model,
    hsv_table_classify,
    white_balance_gains,
)
from armlab.detection.detect import Block, DetectionSettings, detect_blocks, detect_objects, stack_levels
from armlab.detection.draw import draw_detections
from armlab.detection.heightmap import height_from_depth, world_from_depth
from armlab.detection.masks import arm_mask

__all__ = ["Block", "ColorModel", "DetectionSettings", "arm_mask", "color_features", "default_color_model",
           "detect_blocks", "detect_objects", "draw_detections", "height_from_depth", "hsv_table_classify",
           "stack_levels", "white_balance_gains", "world_from_depth"]
