"""Batch specifications: which photos, which seeds, which options (``barkgen batch SPEC.yaml``).

A spec is a YAML (or JSON) mapping::

    size: 512x512          # every pipeline option of barkgen generate, for all exemplars ...
    tile: true
    k: 3
    material: false
    exemplars:
      - {name: oak, path: photos/oak.jpg, seeds: [0, 1, 2]}
      - {name: pine, path: photos/pine.jpg, count: 8, seed_base: 100, k: 4}   # ... or one
      - {library: 3, count: 4}   # a photo of the exemplar library (barkgen library list)

Relative paths are relative to the spec file. Everything is checked here, before any work
starts, and every problem is one :class:`~barkgen.errors.InvalidInputError` line that says
where it is.
"""

from __future__ import annotations

import dataclasses
import difflib
import json
import re
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

from barkgen._shared.options import OptionField, option_fields
from barkgen.batch.manifest import MANIFEST_NAME
from barkgen.errors import BarkgenError, InvalidInputError
from barkgen.pipeline import GenerateOptions

#: keys a spec may set at the top level or per exemplar besides GenerateOptions' fields: the
#: texture's bits, the material set's file name, its preset and its set of sizes
FILE_KEYS = ("bits", "material_name", "preset", "sizes")
#: every option key: the GenerateOptions fields batch offers (barkgen._shared.options), and
#: FILE_KEYS
OPTION_KEYS = tuple(f.name for f in option_fields(GenerateOptions, "batch")) + FILE_KEYS
#: keys of an exemplar entry besides the options
EXEMPLAR_KEYS = ("name", "path", "library", "labels", "seeds", "count", "seed_base", "licence")
#: top-level keys besides the options
TOP_KEYS = ("exemplars",)

_NAME_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]{0,63}$")
#: most variants one exemplar entry may ask for
MAX_VARIANTS = 100_000
#: bounds of a spec file, checked before it is built: its size, its YAML aliases, its exemplars
MAX_SPEC_BYTES = 4 * 2**20
MAX_SPEC_ALIASES = 16
MAX_EXEMPLARS = 10_000


@dataclass(frozen=True)
class ExemplarJob:
    """One exemplar of a batch: its output ``name`` (the folder under OUTDIR), the photo, an
    optional label map of it, the seeds of its variants, its :class:`GenerateOptions` (the
    seed field aside), the material set's asset name ``material_name`` (None: the exemplar's
    ``name``, each set named with its seed, :mod:`barkgen.io.asset_names`), the photo's
    ``licence`` and the texture's ``bits``."""

    name: str
    path: Path
    seeds: tuple[int, ...]
    options: GenerateOptions
    labels: Path | None = None
    bits: int | None = None
    material_name: str | None = None
    preset: str = "ambientcg"
    sizes: tuple[int, ...] = ()
    source: str | None = None
    licence: str | None = None
    asset: str | None = None

    def set_base_name(self, seed: int) -> tuple[str, str | None]:
        """The set's asset name and variant for ``seed``: ``material_name`` as given (with the
        seed when the entry has several), else the photo's own name (``asset``: its file's,
        its library exemplar's, its scanned set's; the entry's ``name`` when unknown) and
        the seed, as ``barkgen generate`` names it."""
        from barkgen.io import set_asset_name

        if self.material_name is None:
            return self.asset or set_asset_name(self.name), f"seed{seed}"
        return self.material_name, f"seed{seed}" if len(self.seeds) > 1 else None

    @property
    def source_name(self) -> str:
        """What the reports call the photo: its path, or ``library:ID (name)``."""
        return self.source or str(self.path)

    def options_for(self, seed: int) -> GenerateOptions:
        return dataclasses.replace(self.options, seed=seed)

    def fingerprint(self) -> str:
        """What a finished variant was made with (the seed aside): a variant recorded with
        another fingerprint is made again."""
        opts = dataclasses.asdict(self.options)
        opts.pop("seed")
        opts.pop("threads")
        opts.pop("max_memory")
        return json.dumps(
            {
                "path": str(self.path),
                "labels": None if self.labels is None else str(self.labels),
                "bits": self.bits,
                "material_name": self.material_name,
                **({"licence": self.licence} if self.licence is not None else {}),
                # (only where set: the fingerprints of earlier batches stay as they were)
                **({"preset": self.preset} if self.preset != "ambientcg" else {}),
                **({"sizes": list(self.sizes)} if self.sizes else {}),
                **opts,
            },
            sort_keys=True,
            default=str,
        )


@dataclass(frozen=True)
class BatchSpec:
    """A validated batch: its exemplars (in spec order) and the spec file's folder."""

    exemplars: tuple[ExemplarJob, ...]
    root: Path

    @property
    def n_variants(self) -> int:
        return sum(len(ex.seeds) for ex in self.exemplars)


def _suggest(key: str, allowed) -> str:
    close = difflib.get_close_matches(key, list(allowed), n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


def _check_keys(where: str, mapping: dict, allowed) -> None:
    for key in mapping:
        if not isinstance(key, str) or key not in allowed:
            raise InvalidInputError(
                f"{where}: unknown key {key!r}{_suggest(str(key), allowed)}; allowed: {', '.join(allowed)}"
            )


def _seed(where: str, value) -> int:
    from barkgen._shared.checks import check_seed

    try:
        return check_seed(value)
    except InvalidInputError as exc:
        raise InvalidInputError(f"{where}: {exc}") from None


def _int(where: str, key: str, value, minimum: int = 0) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
        raise InvalidInputError(f"{where}: {key} must be an integer >= {minimum}, not {value!r}")
    return value


def _option_value(where: str, field: OptionField, value):
    """A spec's value of one GenerateOptions field, read as its kind (YAML reads ``yes`` and
    ``no`` as booleans; a size may be one number, a square)."""
    kind, key = field.info.kind, field.name
    if kind is bool:
        if not isinstance(value, bool):
            raise InvalidInputError(f"{key} must be true or false, not {value!r}")
        return value
    if kind is int:
        minimum = field.info.minimum
        return _int(where, key, value, -(2**63) if minimum is None else int(minimum))
    if kind is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise InvalidInputError(f"{key} must be a number, not {value!r}")
        return float(value)
    if isinstance(value, bool) and field.info.choices and "yes" in field.info.choices:
        value = "yes" if value else "no"
    elif isinstance(value, int) and not isinstance(value, bool) and key == "size":
        value = f"{value}x{value}"
    return field.read(str(value))


def _options(
    where: str, values: dict, threads: int | None, options_class: type = GenerateOptions
) -> tuple[GenerateOptions, dict]:
    """GenerateOptions (or ``options_class``) from a spec's option keys, and the files' own
    (``bits``, ``material_name``, ``preset``, ``sizes``: :data:`FILE_KEYS`); errors say where."""
    from barkgen.material.presets import check_preset
    from barkgen.pipeline import check_generate_names, parse_sizes, sized_options

    try:
        kwargs = {
            f.name: _option_value(where, f, values[f.name])
            for f in option_fields(options_class, "batch")
            if f.name in values
        }
        bits = values.get("bits")
        if bits is not None and (isinstance(bits, bool) or bits not in (8, 16)):
            raise InvalidInputError(f"bits must be 8 or 16, not {bits!r}")
        name = values.get("material_name")
        if name is not None:
            check_generate_names(str(name), words=("material_name", "extra"))
        preset = check_preset(str(values.get("preset", "ambientcg")))
        sizes = parse_sizes(values.get("sizes"), "sizes")
        options = sized_options(options_class(threads=threads, **kwargs), sizes)
        material_name = None if name is None else str(name)
        return options, {"bits": bits, "material_name": material_name, "preset": preset, "sizes": tuple(sizes)}
    except BarkgenError as exc:
        message = str(exc)
        if message.startswith(where):
            raise
        raise InvalidInputError(f"{where}: {message}") from None


def _licence(where: str, entry: dict, library_licence: str | None) -> str | None:
    """The entry's ``licence`` (one line of text), else its library exemplar's."""
    licence = entry.get("licence", library_licence)
    if licence is not None and (not isinstance(licence, str) or not licence.strip() or "\n" in licence):
        raise InvalidInputError(f"{where}: licence must be one line of text (e.g. CC0-1.0), not {licence!r}")
    return licence


def _seeds(where: str, entry: dict) -> tuple[int, ...]:
    if "seeds" in entry:
        if "count" in entry or "seed_base" in entry:
            raise InvalidInputError(f"{where}: give seeds, or count (and seed_base), not both")
        seeds = entry["seeds"]
        if isinstance(seeds, int) and not isinstance(seeds, bool):
            seeds = [seeds]
        if not isinstance(seeds, list) or not seeds:
            raise InvalidInputError(f"{where}: seeds must be a non-empty list of integers, not {seeds!r}")
        if len(seeds) > MAX_VARIANTS:
            raise InvalidInputError(f"{where}: {len(seeds)} seeds is more than {MAX_VARIANTS}")
        seeds = [_seed(where, s) for s in seeds]
        dup = sorted(s for s, n in Counter(seeds).items() if n > 1)
        if dup:
            raise InvalidInputError(
                f"{where}: seed {dup[0]} is listed twice (two variants would write the same folder)"
            )
        return tuple(seeds)
    if "count" not in entry:
        raise InvalidInputError(
            f"{where}: say which variants to make: seeds: [0, 1, ...] or count: N (with seed_base: S, default 0)"
        )
    count = _int(where, "count", entry["count"], 1)
    if count > MAX_VARIANTS:
        raise InvalidInputError(f"{where}: count {count} is more than {MAX_VARIANTS}")
    base = _seed(where, entry.get("seed_base", 0))
    _seed(where, base + count - 1)
    return tuple(range(base, base + count))


def _path(root: Path, where: str, key: str, value, folder: bool = False) -> Path:
    """A spec's file (or, with ``folder``, a scanned set's folder too), relative to ``root``."""
    if not isinstance(value, str) or not value.strip():
        raise InvalidInputError(f"{where}: {key} must be a file path, not {value!r}")
    path = Path(value).expanduser()
    path = path if path.is_absolute() else root / path
    if not (path.is_file() or (folder and path.is_dir())):
        raise InvalidInputError(f"{where}: {key} {value!r} not found ({path})")
    return path


def _library_photo(where: str, entry: dict, library) -> tuple[Path, str, str, str | None]:
    """``library: ID`` -> the exemplar's stored photo, its default output name, source and
    licence."""
    from barkgen.library import Library, NotFoundError

    if "path" in entry:
        raise InvalidInputError(f"{where}: give the photo as path: or library:, not both")
    exemplar_id = entry["library"]
    if isinstance(exemplar_id, bool) or not isinstance(exemplar_id, int):
        raise InvalidInputError(f"{where}: library must be an exemplar id (barkgen library list), not {exemplar_id!r}")
    if library is None or isinstance(library, (str, Path)):
        library = Library(library)
    try:
        exemplar = library.exemplar(exemplar_id)
    except NotFoundError:
        raise InvalidInputError(
            f"{where}: no exemplar {exemplar_id} in the library at {library.path} (see barkgen library list)"
        ) from None
    name = re.sub(r"[^A-Za-z0-9._-]+", "-", exemplar.name).strip("-.")[:64] or f"library-{exemplar.id}"
    source = f"library:{exemplar.id} ({exemplar.name})"
    return library.store.path(exemplar.photo_hash), name, source, exemplar.licence


def parse_spec(document, root: str | Path = ".", *, threads: int | None = None, library=None) -> BatchSpec:
    """Validate a spec mapping (as loaded from YAML); relative paths are relative to ``root``.

    ``threads``: numba/faiss threads of each variant (None: all cores of its worker).
    ``library``: the :class:`~barkgen.library.Library` (or its folder) that ``library: ID``
    entries name (None: the default library).

    Raises:
        InvalidInputError: one line naming the entry and the key at fault: unknown keys,
            missing photos, bad sizes or options, duplicate output names or seeds.
    """
    from barkgen.io import photo_asset_name, set_asset_name

    root = Path(root)
    if not isinstance(document, dict):
        raise InvalidInputError(f"spec: expected a mapping with an 'exemplars' list, not {type(document).__name__}")
    _check_keys("spec", document, TOP_KEYS + OPTION_KEYS)
    entries = document.get("exemplars")
    if not isinstance(entries, list) or not entries:
        raise InvalidInputError("spec: 'exemplars' must be a non-empty list of {name, path, seeds | count} entries")
    if len(entries) > MAX_EXEMPLARS:
        raise InvalidInputError(f"spec: {len(entries)} exemplars is more than {MAX_EXEMPLARS}")
    shared = {key: value for key, value in document.items() if key in OPTION_KEYS}
    _options("spec", shared, threads)  # top-level options are checked once, on their own
    jobs: list[ExemplarJob] = []
    total = 0
    names: dict[str, int] = {}
    for i, entry in enumerate(entries):
        where = f"spec: exemplars[{i}]"
        if not isinstance(entry, dict):
            raise InvalidInputError(
                f"{where}: expected a mapping such as {{name: oak, path: oak.jpg, seeds: [0, 1]}}, not {entry!r}"
            )
        _check_keys(where, entry, EXEMPLAR_KEYS + OPTION_KEYS)
        source, licence = None, None
        if "library" in entry:
            path, default_name, source, licence = _library_photo(where, entry, library)
            asset: str | None = set_asset_name(default_name)
        elif "path" not in entry:
            raise InvalidInputError(f"{where}: path (the bark photo) or library (an exemplar id) is missing")
        else:
            path = _path(root, where, "path", entry["path"], folder=True)
            default_name = path.name if path.is_dir() else path.stem
            asset = None if path.is_dir() else photo_asset_name(path)  # (a scanned set's: when it is read)
        name = entry.get("name", default_name)
        if not isinstance(name, str) or not _NAME_RE.match(name) or name in (".", ".."):
            raise InvalidInputError(
                f"{where}: name {name!r} must be a folder name of letters, digits, "
                "'.', '_' or '-' (at most 64, not starting with a dot)"
            )
        where = f"spec: exemplars[{i}] ({name})"
        if name.lower() == MANIFEST_NAME:
            raise InvalidInputError(f"{where}: {MANIFEST_NAME} is the batch's manifest; name the exemplar otherwise")
        if name.lower() in names:
            raise InvalidInputError(
                f"{where}: the name {name!r} is also exemplars[{names[name.lower()]}]'s; "
                "each exemplar needs its own output folder"
            )
        names[name.lower()] = i
        labels = _path(root, where, "labels", entry["labels"]) if "labels" in entry else None
        options, files = _options(where, {**shared, **{k: v for k, v in entry.items() if k in OPTION_KEYS}}, threads)
        if path.is_dir():  # a scanned set: its maps go into the material set
            options = dataclasses.replace(options, material=True)
        jobs.append(
            ExemplarJob(
                name=name,
                path=path,
                seeds=_seeds(where, entry),
                options=options,
                labels=labels,
                source=source,
                licence=_licence(where, entry, licence),
                asset=asset,
                **files,
            )
        )
        total += len(jobs[-1].seeds)
        if total > MAX_VARIANTS:  # (checked as they add up: 300 x 100,000 seeds are never built)
            raise InvalidInputError(f"spec: {total} variants or more; at most {MAX_VARIANTS} in one batch (split it)")
    return BatchSpec(exemplars=tuple(jobs), root=root)


def _load_document(text: str, name: str):
    """The spec's document: JSON when it is JSON (no aliases, parsed at C speed), else YAML
    (libyaml's safe loader when PyYAML has it), its aliases counted before anything is built:
    a few hundred bytes of nested aliases (a "billion laughs") expand to billions of entries."""
    import yaml

    try:
        return json.loads(text)
    except ValueError:
        pass
    loader = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
    aliases = sum(isinstance(e, yaml.AliasEvent) for e in yaml.parse(text, Loader=loader))
    if aliases > MAX_SPEC_ALIASES:
        raise InvalidInputError(f"spec {name!r} uses {aliases} YAML aliases (*name); at most {MAX_SPEC_ALIASES}")
    return yaml.load(text, Loader=loader)  # noqa: S506 - a safe loader


def load_spec(path: str | Path, *, threads: int | None = None, library=None) -> BatchSpec:
    """Read and validate a spec file (YAML or JSON); see :func:`parse_spec`."""
    import yaml

    path = Path(path)
    if not path.is_file():
        raise InvalidInputError(f"spec {str(path)!r} not found")
    try:
        if path.stat().st_size > MAX_SPEC_BYTES:
            raise InvalidInputError(
                f"spec {str(path)!r} is over {MAX_SPEC_BYTES // 2**20} MiB; "
                "a spec lists photos and seeds, it is never that long"
            )
        text = path.read_text(encoding="utf-8")
        document = _load_document(text, str(path))
    except UnicodeDecodeError:
        raise InvalidInputError(f"spec {str(path)!r} is not a text file") from None
    except RecursionError:
        raise InvalidInputError(f"spec {str(path)!r} is nested too deeply") from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        at = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or "not valid YAML"
        raise InvalidInputError(f"spec {str(path)!r}: {problem}{at}") from None
    return parse_spec(document, path.resolve().parent, threads=threads, library=library)
