"""Mitsuba 3 XML's values, transforms and parameters, read as Mitsuba reads them (the base of
:mod:`.importer`; every error names the file, the line, the element and the way out).

* Parameters: ``<default name value>`` at the top of the scene, ``$name`` substituted in every
  attribute of every element after it (``type`` included); a ``$name`` with no default before
  it is an error, as in Mitsuba ("undefined parameter").
* Values: ``float``, ``integer``, ``string``, ``boolean``, ``point`` and ``vector`` (``value``
  or ``x``/``y``/``z``), ``rgb`` (one number or three) and ``spectrum`` of one number.  A
  spectrum of one value v is grey (v, v, v) as a reflectance, but on an emitter it is an
  equal-energy (flat) spectrum, whose colour Mitsuba's RGB variants take as
  v * :data:`FLAT_EMITTER_RGB`.  A spectrum of ``wavelength:value`` pairs is taken to linear
  sRGB as Mitsuba's RGB variants take it (:mod:`.spectra`).  Spectra from a
  ``filename`` are refused (give ``<rgb>``).
* Transforms: ``translate``, ``rotate`` (axis and angle), ``scale``, ``matrix`` (9 or 16
  numbers) and ``lookat``, composed in order (each applied after the ones before it).  A
  ``lookat`` without ``up`` takes Mitsuba's: the first vector of
  :func:`coordinate_system` of the view direction.
"""

from __future__ import annotations

import math
import re
import warnings
import xml.etree.ElementTree as ET
from pathlib import Path
from xml.parsers import expat

import numpy as np
import trimesh

from blockhash.errors import InputError
from blockhash.scene.mitsuba.spectra import XYZ_TO_SRGB, to_srgb

#: The RGB Mitsuba's RGB variants give an emitter's ``<spectrum value="1"/>``: the flat
#: (equal-energy) spectrum has CIE XYZ (1, 1, 1) at luminance 1, and in linear sRGB, whose
#: white is D65, that is XYZ_TO_SRGB @ (1, 1, 1) = (1.2048, 0.9483, 0.9089), not grey.
#: (A reflectance spectrum is converted under D65, so value v there stays (v, v, v).)
FLAT_EMITTER_RGB = XYZ_TO_SRGB @ np.ones(3)


class MitsubaWarning(UserWarning):
    """A Mitsuba scene element blockhash renders otherwise than Mitsuba (the message says how)."""


#: How far from orthonormal the sensor's to_world may be (Mitsuba's ``has_scale``:
#: |M^T M - I| above this in any entry is a scale or a shear).
ORTHONORMAL_TOLERANCE = 1e-3
_PARAM = re.compile(r"\$([A-Za-z_][A-Za-z0-9_]*)")


def coordinate_system(n) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors (s, t) completing unit ``n`` to an orthonormal frame: Mitsuba's
    ``coordinate_system`` (Duff et al. 2017), whose s is the ``up`` of a ``lookat``
    written without one."""
    n = np.asarray(n, dtype=np.float64)
    sign = math.copysign(1.0, n[2])
    a = -1.0 / (sign + n[2])
    b = n[0] * n[1] * a
    s = np.array([1.0 + sign * n[0] * n[0] * a, sign * b, -sign * n[0]])
    t = np.array([b, sign + n[1] * n[1] * a, -n[1]])
    return s, t


class _Builder(ET.TreeBuilder):
    """An element tree built from expat's events, keeping comments and each element's line."""

    def __init__(self):
        super().__init__(insert_comments=True)
        self.lines: dict[int, int] = {}

    def parse(self, data: bytes):
        parser = expat.ParserCreate()

        def start(tag, attrs):
            self.lines[id(self.start(tag, attrs))] = parser.CurrentLineNumber

        parser.StartElementHandler = start
        parser.EndElementHandler = self.end
        parser.CommentHandler = self.comment
        parser.Parse(data, True)
        return self.close()


def parse(path: Path):
    """(root element, {id(element): line}) of the XML file at ``path``."""
    builder = _Builder()
    try:
        root = builder.parse(path.read_bytes())
    except expat.ExpatError as exc:
        # file:line:col (expat's column is 0-based), as editors and terminals link it
        what = expat.ErrorString(exc.code) if exc.code else str(exc)
        raise InputError(f"{path}:{exc.lineno}:{exc.offset + 1}: XML syntax error: {what}; fix "
                         "the file there (an unclosed or mismatched tag, a stray '<' or '&', "
                         "or an empty file)") from None
    except OSError as exc:
        raise InputError(f"{path}: cannot read the file: {exc}") from None
    return root, builder.lines


class XmlReader:
    """Values and transforms of one file, each error naming the element and its line."""

    def __init__(self, path: Path, lines: dict):
        self.path = path
        self.lines = lines
        self.defaults: dict[str, str] = {}
        #: id(element) -> its attributes as written, for those that held a $name.
        self.raw: dict[int, dict] = {}
        #: id(element) -> the file it was read from, for the elements of included files.
        self.files: dict[int, Path] = {}
        #: The folders of the file's <path> elements, searched (the last given first) before
        #: the folder of the file that names a file (:meth:`resolve`).
        self.search: list[Path] = []
        self.kept: list = []  # included files' roots: their elements' ids stay theirs
        #: The file the scene was loaded from (an included file's reader shares it).
        self.top = path
        #: Top-level <sampler id> and <texture id> elements, which a sensor and a BSDF take
        #: by <ref id>.
        self.samplers: dict = {}
        self.textures: dict = {}

    def where(self, el) -> str:
        return f"{self.file_of(el)}:{self.lines.get(id(el), '?')}"

    def file_of(self, el) -> Path:
        """The file ``el`` was read from (an included file's elements keep theirs)."""
        return self.files.get(id(el), self.path)

    def resolve(self, el, name: str, what: str) -> Path:
        """The file ``name`` that ``el`` names: as given when absolute, else in each folder of
        a ``<path>`` (the last given first), then beside the top file and the file ``el`` is
        in, as Mitsuba's file resolver looks (:meth:`places`); an error listing where it
        looked when none holds it."""
        return self._find(el, name, Path.is_file, f"{what} not found",
                          " (a relative name is searched in each <path value> folder, then "
                          "beside the XML file); fix the name or add <path value=\"FOLDER\"/>")

    def folder(self, el, value: str) -> Path:
        """The folder a ``<path value>`` names, through :meth:`places`."""
        return self._find(el, value, Path.is_dir, "folder not found",
                          "; a <path value> names a folder to search for the files the scene "
                          "names")

    def _find(self, el, name: str, test, missing: str, way_out: str) -> Path:
        places = self.places(el, Path(name))
        for place in places:
            if test(place):
                return place
        self.fail(el, f"{missing}: {name!r}, looked for at "
                  + ", ".join(repr(str(p)) for p in places) + way_out)

    def places(self, el, given: Path) -> list[Path]:
        """Where a relative name is looked for, in order, as Mitsuba's file resolver looks:
        each ``<path>`` folder (the last given first), the top file's folder, then the folder
        of the (included) file that names it."""
        if given.is_absolute():
            return [given]
        bases = [*reversed(self.search), self.top.parent, self.file_of(el).parent]
        return list(dict.fromkeys(d / given for d in bases))

    def expand(self, root, stack: tuple[Path, ...] = ()) -> None:
        """Read ``root``'s ``<path>`` elements into :attr:`search` and put each ``<include
        filename>``'s scene in its place, recursively (an include that includes itself, even
        through others, is an error naming the chain)."""
        stack = stack or (self.path.resolve(),)
        for el in list(root):
            if el.tag == "path":
                extra = sorted(set(el.attrib) - {"value"})
                if extra:
                    self.fail(el, f"unsupported attribute(s) {extra}; a <path> takes value")
                self.search.append(self.folder(el, self.attr(el, "value")))
                root.remove(el)
            elif el.tag == "include":
                extra = sorted(set(el.attrib) - {"filename"})
                if extra:
                    self.fail(el, f"unsupported attribute(s) {extra}; an <include> takes filename")
                target = self.resolve(el, self.attr(el, "filename"), "included file")
                if target.resolve() in stack:
                    chain = " -> ".join(str(p) for p in (*stack, target.resolve()))
                    self.fail(el, f"an include cycle: {chain}; remove one of these includes")
                sub, lines = parse(target)
                self.kept.append(sub)
                if sub.tag != "scene":
                    self.fail(el, f"{target} holds <{sub.tag}> at its top; an included file "
                              "holds a <scene> whose elements are read in place of the include")
                self.lines.update(lines)
                for kid in sub.iter():
                    self.files.setdefault(id(kid), target)
                inner = XmlReader(target, self.lines)
                inner.files, inner.search, inner.kept = self.files, self.search, self.kept
                inner.top = self.top
                inner.expand(sub, (*stack, target.resolve()))
                at = list(root).index(el)
                root.remove(el)
                for offset, kid in enumerate(k for k in sub):
                    root.insert(at + offset, kid)

    def fail(self, el, what: str):
        raise InputError(f"{self.where(el)}: <{el.tag}"
                         + (f" type=\"{el.get('type')}\"" if el.get("type") else "")
                         + (f" name=\"{el.get('name')}\"" if el.get("name") else "")
                         + f">: {what}")

    def build(self, el, cls, **kwargs):
        """``cls(**kwargs)``, its InputError naming ``el`` and its line."""
        try:
            return cls(**kwargs)
        except InputError as exc:
            self.fail(el, str(exc))

    def substitute(self, root) -> None:
        """Read the top-level ``<default>``s and put their values for ``$name`` in every
        attribute of every element after them, in document order (as Mitsuba does)."""
        for el in root.iter():
            if not isinstance(el.tag, str):
                continue
            if any("$" in v for v in el.attrib.values()):
                self.raw[id(el)] = dict(el.attrib)
            for key, value in el.attrib.items():
                el.set(key, _PARAM.sub(lambda m, el=el: self._param(el, m.group(1)), value))
            if el.tag == "default":
                if el not in list(root):
                    self.fail(el, "a <default> must sit directly in <scene>; move it to the top")
                extra = sorted(set(el.attrib) - {"name", "value"})
                if extra:
                    self.fail(el, f"unsupported attribute(s) {extra}; a <default> takes name and value")
                self.defaults.setdefault(self.attr(el, "name"), self.attr(el, "value"))

    def _param(self, el, name: str) -> str:
        if name not in self.defaults:
            self.fail(el, f"undefined parameter ${name} (Mitsuba refuses it too); give it a "
                      f"value as Mitsuba's -D {name}=VALUE does (the render's defines), or add "
                      f"<default name=\"{name}\" value=\"...\"/> at the top of the scene, "
                      "before its first use")
        return self.defaults[name]

    def attr(self, el, key: str, default=None) -> str:
        v = el.get(key)
        if v is None:
            if default is not None:
                return default
            self.fail(el, f"missing attribute {key!r}")
        return v

    def floats(self, el, text: str, count: int | None = None) -> np.ndarray:
        try:
            v = np.array([float(t) for t in text.replace(",", " ").split()], dtype=np.float64)
        except ValueError:
            self.fail(el, f"expected numbers; got {text!r}")
        if count is not None and len(v) != count:
            self.fail(el, f"expected {count} numbers; got {len(v)} ({text!r})")
        if not np.isfinite(v).all():
            self.fail(el, f"expected finite numbers; got {text!r}")
        return v

    def value(self, el, *, emitter: bool = False, unbounded: bool = False):
        """The value of property element ``el``; ``emitter``: it is an emitter's (a
        spectrum there is an illuminant, module docstring); ``unbounded``: a value above 1 is
        not clipped (a conductor's eta and k, :mod:`.spectra`)."""
        tag = el.tag
        if tag in ("float", "integer"):
            v = self.floats(el, self.attr(el, "value"), 1)[0]
            if tag == "integer" and v != int(v):
                self.fail(el, f"expected an integer; got {self.attr(el, 'value')!r}")
            return int(v) if tag == "integer" else float(v)
        if tag == "string":
            return self.attr(el, "value")
        if tag == "boolean":
            v = self.attr(el, "value").lower()
            if v not in ("true", "false"):
                self.fail(el, f"expected true or false; got {v!r}")
            return v == "true"
        if tag == "rgb":
            v = self.floats(el, self.attr(el, "value"))
            if len(v) not in (1, 3):
                self.fail(el, "expected one number or three (r, g, b)")
            return np.broadcast_to(v, (3,)).copy()
        if tag == "spectrum":
            return self.spectrum(el, emitter, unbounded)
        if tag in ("point", "vector"):
            return self.value_xyz(el, 0.0)
        if tag == "transform":
            return self.transform(el)
        self.fail(el, "unsupported property; supported: float, integer, string, boolean, rgb, "
                  "spectrum, point, vector, transform")

    def spectrum(self, el, emitter: bool, unbounded: bool = False) -> np.ndarray:
        if el.get("filename") is not None:
            self.fail(el, "a spectrum read from a file is not supported; give its colour as "
                      "<rgb value=\"r, g, b\"/>")
        text = self.attr(el, "value")
        if ":" in text:
            return self.sampled_spectrum(el, text, emitter, unbounded)
        v = self.floats(el, text, 1)[0]
        return v * FLAT_EMITTER_RGB if emitter else np.full(3, v)

    def sampled_spectrum(self, el, text: str, emitter: bool, unbounded: bool) -> np.ndarray:
        """The linear sRGB of a spectrum of ``wavelength:value`` pairs, as Mitsuba's RGB
        variants take it (:mod:`.spectra`)."""
        pairs = [p.strip() for p in text.split(",") if p.strip()]
        try:
            wl, v = np.array([[float(x) for x in p.split(":")] for p in pairs]).T
        except ValueError:
            self.fail(el, f"expected wavelength:value pairs such as \"400:0.3, 500:0.5\"; got "
                      f"{text!r}")
        if not (np.isfinite(wl).all() and np.isfinite(v).all()):
            self.fail(el, f"expected finite wavelengths and values; got {text!r}")
        if len(wl) < 2 or not (np.diff(wl) > 0).all():
            self.fail(el, "expected at least two wavelength:value pairs in increasing "
                      f"wavelength; got {text!r}")
        rgb, clipped = to_srgb(wl, v, emitter=emitter, unbounded=unbounded)
        if clipped:
            warnings.warn(f"{self.where(el)}: <spectrum value=\"{text}\">: its colour lies "
                          f"outside {'the positive channels' if emitter or unbounded else '[0, 1]'} of linear "
                          f"sRGB and is clipped to {np.round(rgb, 4).tolist()}, as Mitsuba's RGB "
                          "variants clip it", MitsubaWarning, stacklevel=2)
        return rgb

    def props(self, el, allowed: dict, *, children=(), emitter: bool = False,
              unbounded=()) -> dict:
        """The named properties of ``el`` (``allowed``: name -> tags), every other child an
        error unless its tag is in ``children`` (returned under ``'<children>'``)."""
        out, kids = {}, []
        for child in el:
            if not isinstance(child.tag, str):
                continue  # a comment
            if child.tag in children:
                kids.append(child)
                continue
            name = child.get("name")
            if name not in allowed:
                self.fail(child, f"unsupported here; <{el.tag} type=\"{el.get('type')}\"> takes "
                          + (", ".join(f"{n} ({'/'.join(t)})" for n, t in allowed.items()) or "nothing")
                          + (f" and {', '.join(children)}" if children else "")
                          + "; remove it or fix its name")
            if name in out:
                self.fail(child, f"{name} is given twice; keep one")
            if child.tag in ("texture", "ref") and "texture" in allowed[name]:
                out[name] = child  # read by the caller (:mod:`.textures`)
                continue
            if child.tag in ("texture", "ref") and "rgb" in allowed[name]:
                what = (f"the texture {child.get('id')!r}" if child.tag == "ref"
                        else f"a {child.get('type')} texture")
                self.fail(child, f"{name} given by {what}: textures are not supported (a "
                          f"material has one colour here); give {name} as <rgb value=\"r, g, "
                          "b\"/>, e.g. the texture's mean colour")
            if child.tag not in allowed[name]:
                self.fail(child, f"{name} must be given as {' or '.join(allowed[name])}")
            out[name] = self.value(child, emitter=emitter, unbounded=name in unbounded)
        out["<children>"] = kids
        return out

    def transform(self, el) -> np.ndarray:
        m = np.eye(4)
        for op in el:
            if not isinstance(op.tag, str):
                continue
            t = np.eye(4)
            if op.tag == "translate":
                t[:3, 3] = self.value_xyz(op, 0.0)
            elif op.tag == "scale":
                if op.get("value") is not None:
                    s = self.floats(op, self.attr(op, "value"))
                    s = np.broadcast_to(s, (3,)) if len(s) in (1, 3) else self.fail(op, "expected 1 or 3 numbers")
                else:
                    s = self.value_xyz(op, 1.0)
                t[:3, :3] = np.diag(s)
            elif op.tag == "rotate":
                angle = math.radians(self.floats(op, self.attr(op, "angle"), 1)[0])
                axis = self.value_xyz(op, 0.0)
                if not np.linalg.norm(axis) > 0:
                    self.fail(op, "the rotation axis is zero; give x, y, z or value")
                t[:3, :3] = trimesh.transformations.rotation_matrix(angle, axis)[:3, :3]
            elif op.tag == "matrix":
                v = self.floats(op, self.attr(op, "value"))
                if len(v) not in (9, 16):
                    self.fail(op, f"expected 9 or 16 numbers; got {len(v)}")
                if len(v) == 9:
                    t[:3, :3] = v.reshape(3, 3)
                else:
                    t = v.reshape(4, 4)
            elif op.tag == "lookat":
                t = self.lookat(op)[0]
            else:
                self.fail(op, "unsupported transform; supported: translate, rotate, scale, "
                          "matrix, lookat")
            m = t @ m
        return m

    def value_xyz(self, op, default: float) -> np.ndarray:
        if op.get("value") is not None:
            return self.floats(op, self.attr(op, "value"), 3)
        return np.array([self.floats(op, self.attr(op, a, str(default)), 1)[0] for a in "xyz"])

    def lookat(self, op):
        """(matrix, origin, target, up as written or Mitsuba's default) of a <lookat>,
        Mitsuba's frame (local +z forward, +x left)."""
        o = self.floats(op, self.attr(op, "origin"), 3)
        t = self.floats(op, self.attr(op, "target"), 3)
        d = t - o
        if not np.linalg.norm(d) > 0:
            self.fail(op, "origin equals target; give a target away from the origin")
        d /= np.linalg.norm(d)
        up = (self.floats(op, op.get("up"), 3) if op.get("up") is not None
              else coordinate_system(d)[0])
        left = np.cross(up, d)
        if not np.linalg.norm(left) > 1e-12:
            self.fail(op, "up is parallel to the view direction (Mitsuba refuses it too); "
                      "give an up across it")
        left /= np.linalg.norm(left)
        m = np.eye(4)
        m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = left, np.cross(d, left), d, o
        return m, o, t, up


__all__ = ["XmlReader", "parse", "coordinate_system", "FLAT_EMITTER_RGB", "XYZ_TO_SRGB",
           "MitsubaWarning"]
