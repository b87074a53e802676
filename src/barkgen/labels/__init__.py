"""Label maps from a bark photo (laitoch2018 §3.5, wang2003 §3.2).

``color_regions`` makes the colour-region label map of the texture-by-numbers pipeline;
``texton_channels`` / ``merge_channels`` / ``auto_merge`` / ``channel_previews`` the texton
channels of Wang et al.;
``add_edge_label`` the optional edge label. Label maps are ``(h, w)`` uint8 images whose evenly
spaced grey values are the labels, the darkest region first.
"""

from barkgen.labels.preview import contact_sheet, label_colour_map, label_preview
from barkgen.labels.regions import add_edge_label, color_regions, remove_small_regions
from barkgen.labels.textons import (
    auto_merge,
    channel_previews,
    filter_bank,
    merge_channels,
    parse_groups,
    texton_channels,
    texton_regions,
)

__all__ = [
    "add_edge_label",
    "auto_merge",
    "channel_previews",
    "color_regions",
    "contact_sheet",
    "filter_bank",
    "label_colour_map",
    "label_preview",
    "merge_channels",
    "parse_groups",
    "remove_small_regions",
    "texton_channels",
    "texton_regions",
]
