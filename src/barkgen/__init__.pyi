# The public names of barkgen: the one list. Type checkers and IDEs read it; barkgen/__init__.py
# reads it too and imports each name lazily, on first use (as scikit-image's stubs do).
from barkgen._version import __version__ as __version__
from barkgen.data import sample_exemplar_path as sample_exemplar_path
from barkgen.errors import BarkgenError as BarkgenError
from barkgen.io import read_image as read_image
from barkgen.io import write_png as write_png
from barkgen.material import HeightEditor as HeightEditor
from barkgen.material import MaterialOptions as MaterialOptions
from barkgen.material import MaterialSet as MaterialSet
from barkgen.material import make_material as make_material
from barkgen.pipeline import GenerateOptions as GenerateOptions
from barkgen.pipeline import GenerateResult as GenerateResult
from barkgen.pipeline import generate as generate
from barkgen.pipeline import warm_up as warm_up
from barkgen.render import render_trunk as render_trunk
from barkgen.render import trunk_mesh as trunk_mesh
from barkgen.shapes import synthesize_label_map as synthesize_label_map
from barkgen.synth import Budget as Budget
from barkgen.synth import Canvas as Canvas
from barkgen.synth import SynthesisConfig as SynthesisConfig
from barkgen.synth import SynthesisResult as SynthesisResult
from barkgen.synth import apply_references as apply_references
from barkgen.synth import synthesize as synthesize
from barkgen.synth import texture_by_numbers as texture_by_numbers

__all__ = [
    "BarkgenError",
    "Budget",
    "Canvas",
    "GenerateOptions",
    "GenerateResult",
    "HeightEditor",
    "MaterialOptions",
    "MaterialSet",
    "SynthesisConfig",
    "SynthesisResult",
    "__version__",
    "apply_references",
    "generate",
    "make_material",
    "read_image",
    "render_trunk",
    "sample_exemplar_path",
    "synthesize",
    "synthesize_label_map",
    "texture_by_numbers",
    "trunk_mesh",
    "warm_up",
    "write_png",
]
