"""Raw images: what each channel's sensor records for a textured 3-D scene
(docs/model.md §10, "Raw images (2-D forward model)").

A :class:`Scene` is a texture (:mod:`splitlf.textures`) on a surface: a fronto-parallel
or slanted :class:`Plane`, or a :class:`DepthMap`. :func:`render` integrates every pixel
of every channel in the Rust core (``_native.render``) and returns a :class:`Raw`: one
2-D float64 array per channel in §10's layout (``sensor``: [m_y, m_x]; ``ideal``:
[k Q + q_y, j Q + q_x]), in units where a pixel of pitch mu_1 on plane L_1 that sees the
whole aperture under a white albedo reads 1 (a fully lit pixel of the seed's halves
reads 1/2). This module holds validation, the random texture's draw, the noise and the
raw file format.

Random streams: a seed s gives two independent NumPy generators,
``np.random.default_rng([s, 0])`` for a :class:`~splitlf.RandomAlbedo`'s cells and
``np.random.default_rng([s, 1])`` for the noise (channel 1's Poisson counts, then its
read noise, then channel 2's, ...), so a given seed gives the same raw bit for bit and
the noise of a raw does not depend on the texture.

Raw files (:meth:`Raw.save`, :meth:`Raw.load`): an uncompressed NumPy ``.npz`` archive
(no pickled objects) with the keys

- ``format``: the string ``"splitlf-raw/1"``;
- ``design``: the design as TOML text (:meth:`splitlf.Design.to_toml` of its general
  form, a ``[design]`` table);
- ``channel1``, ..., ``channelC``: each channel's raw, float64 [row, col];
- ``noise`` (optional; absent: not stated, as in files written before it existed): the
  noise model the raw carries (:attr:`Raw.noise`), float64 [photons, read_noise], photons
  ``inf`` for a noise-free raw;
- ``cfa`` and ``qe`` (optional; absent: a grey raw, as in files written before colour):
  the colour filter array the raw was mosaiced with (:attr:`Raw.cfa`), the pattern's name
  and float64 [red, green, blue] quantum efficiencies;
- ``falloff`` (optional; absent: off, as in files written before it existed): the
  radiometric falloff the raw was rendered with (:attr:`Raw.falloff`), the string
  ``"microlens"``, ``"main"`` or ``"both"``.
"""

from __future__ import annotations

import concurrent.futures as cf
import dataclasses
import math
import numbers
import os
import sys
import zipfile
from collections.abc import Mapping, Sequence
from typing import Any, cast, overload

import numpy as np

from .. import _native, _validate
from .._files import atomic_output
from .._noise import NOISE_FREE
from .._noise import add_noise as _add_noise
from .._noise import options as _noise
from .._noise import seed as _seed
from .._noise import stated as _stated
from .._progress import progress_bar as _progress
from .._progress import progress_flag as _progress_flag
from .._validate import extent as _extent
from .._validate import finite as _finite
from ..errors import InvalidParameter
from ..model.design import Design
from . import cfa as _cfa
from .bands import ScenePart, check_options, check_raws_fit, render_bands
from .texture import TEXTURES, ColourTexture, Constant, Image, RandomAlbedo
from .texture import albedo as _albedo

__all__ = ["FORMAT", "DepthMap", "Plane", "Raw", "Scene", "render"]

#: The ``format`` entry of a raw file.
FORMAT = "splitlf-raw/1"
#: Rounds of the fixed point that sizes a random texture for a slanted plane.
_EXTENT_ROUNDS = 64
#: A random texture on a slanted plane covers depths up to this many times z0 (a plane
#: seen at grazing incidence reaches any depth; beyond, the albedo is the texture's mean).
RANDOM_DEPTH_FACTOR = 4.0

Extent = tuple[float, float, float, float]


def _real_array(value: Any, name: str) -> np.ndarray:
    """A non-empty 2-D numeric array as a read-only float64 copy, else ``TypeError`` or
    :class:`InvalidParameter` naming ``name``."""
    a = np.asarray(value)
    if a.dtype == object or not (np.issubdtype(a.dtype, np.floating)
                                 or np.issubdtype(a.dtype, np.integer)):
        raise TypeError(f"{name} must be a 2-D array of real numbers, got dtype {a.dtype}")
    if a.ndim != 2 or min(a.shape) < 1:
        raise InvalidParameter.of(name, f"an array of shape {a.shape}", "a non-empty 2-D array")
    a = np.array(a, dtype=np.float64, order="C")
    a.setflags(write=False)
    return a


# -- surfaces ----------------------------------------------------------------------------------

@dataclasses.dataclass(frozen=True)
class Plane:
    """The plane Z = z0 + gx X + gy Y [mm] (gx = gy = 0: fronto-parallel at depth z0).

    ``z0`` finite > 0 (the render also needs the plane in front of the main lens's focal
    plane, Z > F, wherever a pixel sees it: the core checks that, knowing the field of
    view); ``gx``, ``gy`` finite slopes. Raises ``TypeError`` and
    :class:`~splitlf.errors.InvalidParameter` naming the field."""

    z0: float
    gx: float = 0.0
    gy: float = 0.0

    def __post_init__(self) -> None:
        if isinstance(self.z0, bool | np.bool_):
            raise TypeError(f"z0 must be a real depth in mm, got {self.z0!r}")
        z0 = _finite(self.z0, "z0")
        if z0 <= 0:
            raise InvalidParameter.of("z0", z0, "a finite depth > 0 mm in front of the main "
                                      "lens (and > F where the render sees it)")
        object.__setattr__(self, "z0", z0)
        object.__setattr__(self, "gx", _finite(self.gx, "gx"))
        object.__setattr__(self, "gy", _finite(self.gy, "gy"))

    def depths(self, extent: Extent) -> tuple[float, float]:
        """The least and greatest depth of the plane over the rectangle ``extent``."""
        x0, x1, y0, y1 = extent
        z = [self.z0 + self.gx * x + self.gy * y for x in (x0, x1) for y in (y0, y1)]
        return min(z), max(z)

    def seam(self) -> tuple[str, list[float], None]:
        """The native scene's surface: ("plane", [z0, gx, gy], None)."""
        return "plane", [self.z0, self.gx, self.gy], None


@dataclasses.dataclass(frozen=True, eq=False)
class DepthMap:
    """Depths [mm] sampled at the centres of uniform cells over ``extent`` (X0, X1, Y0,
    Y1) [mm] (row 0 at the top, Y1; column 0 at the left, X0): bilinear between centres,
    constant beyond the outer centres up to the extent's edge, no surface outside it (rays
    there see the scene's background).

    ``depth`` a non-empty 2-D array of finite depths > 0; ``extent`` finite with X0 < X1,
    Y0 < Y1; ``confidence`` (a per-sample weight, e.g. of a depth estimate) and
    ``confident`` (a per-sample bool) optional arrays of the same shape, carried along;
    ``sweep`` what :func:`~splitlf.estimate_depth` saw (a
    :class:`~splitlf.depth_estimation.DepthSweep`), carried along.
    The arrays are kept as read-only float64 (bool) copies. Raises ``TypeError`` and
    :class:`~splitlf.errors.InvalidParameter` naming the field (and the element)."""

    depth: np.ndarray
    extent: Extent
    confidence: np.ndarray | None = None
    confident: np.ndarray | None = None
    sweep: Any = None

    def __post_init__(self) -> None:
        z = _real_array(self.depth, "depth")
        bad = np.flatnonzero(~(np.isfinite(z) & (z > 0)))
        if bad.size:
            i = int(bad[0])
            r, c = divmod(i, z.shape[1])
            allowed = "finite depths > 0 mm"
            value = float(z.flat[i])
            raise InvalidParameter(f"invalid depth[{r}, {c}] = {value!r}: allowed {allowed}",
                                   name="depth", value=value, allowed=allowed, index=i)
        object.__setattr__(self, "depth", z)
        object.__setattr__(self, "extent", _extent(self.extent))
        if self.confidence is not None:
            c = _real_array(self.confidence, "confidence")
            if c.shape != z.shape:
                raise InvalidParameter.of("confidence", f"shape {c.shape}",
                                          f"the depth's shape {z.shape}")
            object.__setattr__(self, "confidence", c)
        if self.confident is not None:
            b = np.array(self.confident)
            if b.dtype != np.bool_ or b.shape != z.shape:
                raise InvalidParameter.of("confident", f"{b.dtype} array of shape {b.shape}",
                                          f"a bool array of the depth's shape {z.shape}")
            b.setflags(write=False)
            object.__setattr__(self, "confident", b)

    def __repr__(self) -> str:
        """A short summary (shape, extent, depth range, confident share), not the arrays."""
        z = self.depth
        parts = [f"shape={z.shape}", "extent=({:g}, {:g}, {:g}, {:g})".format(*self.extent),
                 f"depth=[{float(z.min()):g}, {float(z.max()):g}] mm"]
        if self.confident is not None:
            parts.append(f"confident={float(np.mean(self.confident)):.0%}")
        if self.confidence is not None:
            parts.append("confidence=array")
        if self.sweep is not None:
            parts.append(f"sweep={type(self.sweep).__name__}")
        return f"DepthMap({', '.join(parts)})"

    def seam(self) -> tuple[str, list[float], np.ndarray]:
        """The native scene's surface: ("depthmap", [X0, X1, Y0, Y1], depth)."""
        return "depthmap", list(self.extent), self.depth

    @overload
    def surface(self, design: Design) -> DepthMap: ...

    @overload
    def surface(self, design: Design, *, plane: bool) -> DepthMap | Plane: ...

    def surface(self, design: Design, *, plane: bool = False) -> DepthMap | Plane:
        """The surface this map stands for, as one that every ray through ``design``'s
        main lens meets at most once (docs/depth.md, "The estimate's surface";
        ``_native.depth_surface``): confident cells hold their depth (weighted by their
        ``confidence``), the others follow their neighbours, a jump between confident
        cells on both sides stays a jump (as steep as the condition allows), and slopes
        are limited to what every ray meets once, so that :func:`~splitlf.reconstruct`
        takes the fast footprint route on it. A surface that no cell leaves by more than
        3 % of its depth is the plane fitted to it (weighted by the confidence): its
        samples are that plane's. Without ``confident`` every cell counts as confident
        (weight ``confidence``, or 1). Returns a new :class:`DepthMap` over the same
        extent and cells, without confidence (it is a surface, not an estimate); with
        ``plane=True`` a surface fitted into a plane is returned as that :class:`Plane`
        (it continues past the map's extent; what :func:`~splitlf.reconstruct` takes)
        when its depth at X = Y = 0 is > 0.
        Raises ``TypeError`` and ``KeyboardInterrupt``."""
        if not isinstance(design, Design):
            raise TypeError(f"design must be a splitlf.Design, got {type(design).__name__}")
        if not isinstance(plane, bool):
            raise TypeError(f"plane must be True or False, got {plane!r}")
        z, _, _, _, fit = _native.depth_surface(design.core, self.depth, self.extent,
                                                self.confidence, self.confident)
        if plane and fit is not None and fit[0] > 0.0:
            # (A Plane's z0, its depth at X = Y = 0, must be > 0; a plane steep enough
            # to pass behind the lens on the axis stays a map.)
            return Plane(*fit)
        return DepthMap(z, self.extent)


def _surface(value: Any) -> Plane | DepthMap:
    if isinstance(value, Plane | DepthMap):
        return value
    if isinstance(value, numbers.Real) and not isinstance(value, bool | np.bool_):
        return Plane(float(value))
    raise TypeError("depth must be a number (a fronto-parallel plane at that depth, mm), a "
                    f"splitlf.Plane or a splitlf.DepthMap, got {type(value).__name__}")


@dataclasses.dataclass(frozen=True, eq=False)
class Scene:
    """A Lambertian surface carrying a texture (docs/model.md §10, "Scene").

    - ``texture``: a :class:`~splitlf.Sinusoid`, :class:`~splitlf.BarChart`,
      :class:`~splitlf.SlantedEdge`, :class:`~splitlf.SiemensStar`,
      :class:`~splitlf.RandomAlbedo`, :class:`~splitlf.Image`, :class:`~splitlf.Constant`,
      a number (a Constant of that albedo) or ``"random"`` (a RandomAlbedo on delta(z)
      cells); or a colour texture (a (rows, cols, 3) :class:`~splitlf.Image`, a
      :class:`~splitlf.ColourTexture`), which renders through a colour filter array only
      (docs/model.md §12)
    - ``depth``: a number (the fronto-parallel plane at that depth [mm], kept as a
      :class:`Plane`), a :class:`Plane` or a :class:`DepthMap`
    - ``background``: the albedo a ray sees when it meets no surface, finite >= 0
      (default: the texture's mean; for a colour texture the mean of its colours' means,
      the same in every colour)

    Raises ``TypeError`` and :class:`~splitlf.errors.InvalidParameter` naming the field."""

    texture: Any
    depth: Any
    background: float | None = None

    def __post_init__(self) -> None:
        tex = self.texture
        if isinstance(tex, str) and tex == "random":
            tex = RandomAlbedo()
        elif isinstance(tex, numbers.Real) and not isinstance(tex, bool | np.bool_):
            tex = Constant(cast(float, tex))  # validated by Constant
        if not isinstance(tex, (*TEXTURES, ColourTexture)):
            raise TypeError("texture must be \"random\", a number (a constant albedo), a "
                            "Sinusoid, BarChart, SlantedEdge, SiemensStar, RandomAlbedo, "
                            "Image, Constant or ColourTexture, got "
                            f"{type(self.texture).__name__} {self.texture!r}"[:300])
        object.__setattr__(self, "texture", tex)
        object.__setattr__(self, "depth", _surface(self.depth))
        bg = float(tex.mean) if self.background is None else self.background
        object.__setattr__(self, "background", _albedo(bg, "background"))

    @property
    def is_colour(self) -> bool:
        """Whether the texture has three colours (docs/model.md §12)."""
        tex = self.texture
        return isinstance(tex, ColourTexture) or (isinstance(tex, Image) and tex.is_colour)

    def colour(self, k: int) -> Scene:
        """Colour ``k``'s grey scene (0 red, 1 green, 2 blue): the colour's texture on
        the same surface and background (a grey scene is itself)."""
        if not self.is_colour:
            return self
        return Scene(self.texture.colour(k), self.depth, self.background)

    def reference_depth(self) -> float:
        """The depth whose delta(z) sizes a default random texture's cells: a plane's z0,
        a depth map's median depth."""
        if isinstance(self.depth, Plane):
            return self.depth.z0
        return float(np.median(self.depth.depth))


# -- the raw -----------------------------------------------------------------------------------

def _expected_shapes(design: Design) -> list[tuple[int, int]]:
    """Each channel's raw shape: (Ky Q, Kx Q) for the ideal layout, (My, Mx) for the
    sensor layout (docs/model.md §10, "Raw image layout")."""
    shapes = []
    for ch in design.resolved():
        if ch["layout"] == "ideal":
            shapes.append((ch["Ky"] * ch["Q"], ch["Kx"] * ch["Q"]))
        else:
            shapes.append((ch["My"], ch["Mx"]))
    return shapes


def _image(value: Any, i: int, shape: tuple[int, int], copy: bool) -> np.ndarray:
    """Channel i + 1's raw as a read-only float64 C array (a copy when ``copy``, else the
    array itself when it already is one: raws the package made)."""
    name = f"images[{i}]"
    a = np.asarray(value)
    if a.dtype == object or not (np.issubdtype(a.dtype, np.floating)
                                 or np.issubdtype(a.dtype, np.integer)):
        raise TypeError(f"{name} must be a 2-D array of real numbers, got dtype {a.dtype}")
    if a.shape != shape:
        raise InvalidParameter(
            f"invalid {name}: shape {a.shape}, allowed {shape} (channel {i + 1}'s raw, "
            "docs/model.md §10)", name=name, value=a.shape, allowed=str(shape))
    out = (np.array(a, dtype=np.float64, order="C") if copy
           else np.ascontiguousarray(a, dtype=np.float64))
    if not np.isfinite(out).all():
        k = int(np.flatnonzero(~np.isfinite(out))[0])
        r, c = divmod(k, shape[1])
        raise InvalidParameter(f"invalid {name}: {out.flat[k]} at [{r}, {c}], allowed finite "
                               "values", name=name, value=float(out.flat[k]),
                               allowed="finite values")
    out.setflags(write=False)
    return out


@dataclasses.dataclass(frozen=True, eq=False)
class Raw:
    """The raw images of a design: ``images[i]`` is channel i + 1's sensor image, a
    read-only float64 2-D array in docs/model.md §10's layout (``ideal``: shape (Ky Q,
    Kx Q), element [k Q + q_y, j Q + q_x]; ``sensor``: shape (My, Mx), element
    [m_y, m_x]). Values are in §10's units (a full-aperture pixel of pitch mu_1 under a
    white albedo reads 1; each channel includes its ``share``).

    ``noise`` is the noise model the raw carries: None (not stated: a reconstruction
    estimates it from the data) or ``{"photons": N, "read_noise": r}`` as
    :func:`render` takes it, with ``photons`` = ``math.inf`` (and ``read_noise`` 0) for a
    noise-free raw. :func:`render` records what it drew (``{"photons": inf, "read_noise":
    0}`` without ``noise``); :meth:`save` and :meth:`load` keep it.

    ``cfa`` is the colour filter array the raw was mosaiced with (docs/model.md §12): None
    (a grey raw) or ``{"pattern": "RGGB" | "GRBG" | "GBRG" | "BGGR", "qe": (r, g, b)}``
    (``qe`` optional, default 1s); :meth:`save` and :meth:`load` keep it, and
    :func:`~splitlf.reconstruct` and :func:`~splitlf.estimate_depth` read it.

    ``falloff`` is the radiometric falloff the raw was rendered with (:func:`render`'s
    ``falloff``): None (off: the paper's paraxial model, and any raw from elsewhere unless
    stated) or ``"microlens"``, ``"main"`` or ``"both"``; :meth:`save` and :meth:`load`
    keep it (a file without it loads as None).

    Built by :func:`render`, or directly to wrap raws from elsewhere (another renderer, a
    real camera): ``images`` a sequence of one array per channel (copied), ``noise``,
    ``cfa`` and ``falloff`` as above (default None). Raises ``TypeError`` and
    :class:`~splitlf.errors.InvalidParameter` (named ``images`` for the count,
    ``images[i]`` for a shape or a value that is not finite, ``noise`` or ``noise photons``
    / ``noise read_noise`` for a bad noise model, ``cfa``, ``qe`` or ``qe[k]`` for a bad
    colour filter array, ``falloff`` for an unknown falloff)."""

    design: Design
    images: tuple[np.ndarray, ...]
    noise: Mapping[str, float] | None = None
    cfa: Mapping[str, Any] | None = None
    falloff: str | None = None

    def __post_init__(self) -> None:
        self._check(copy=True)

    @classmethod
    def _adopt(cls, design: Design, images: Sequence[np.ndarray],
               noise: Mapping[str, float] | None = None,
               cfa: Mapping[str, Any] | None = None, falloff: str | None = None) -> Raw:
        """A Raw of arrays this package made (the core's raws, a loaded file): checked
        like any, but kept without a copy (a render's peak memory stays the raws')."""
        raw = object.__new__(cls)
        object.__setattr__(raw, "design", design)
        object.__setattr__(raw, "images", images)
        object.__setattr__(raw, "noise", noise)
        object.__setattr__(raw, "cfa", cfa)
        object.__setattr__(raw, "falloff", falloff)
        raw._check(copy=False)
        return raw

    def _check(self, copy: bool) -> None:
        design = _validate.design(self.design)
        imgs = self.images
        if isinstance(imgs, np.ndarray) or not isinstance(imgs, Sequence):
            raise TypeError("images must be a sequence of 2-D arrays, one per channel, got "
                            f"{type(imgs).__name__}")
        shapes = _expected_shapes(design)
        if len(imgs) != len(shapes):
            raise InvalidParameter.of("images", f"{len(imgs)} arrays",
                                      f"one array per channel: {len(shapes)}")
        object.__setattr__(self, "images", tuple(_image(a, i, s, copy) for i, (a, s)
                                                 in enumerate(zip(imgs, shapes, strict=True))))
        object.__setattr__(self, "noise", _stated(self.noise, "noise"))
        object.__setattr__(self, "cfa", _cfa.stated(self.cfa))
        object.__setattr__(self, "falloff", falloff_option(self.falloff))

    def __repr__(self) -> str:
        """A short summary (each channel's shape and value range), not the arrays."""
        chans = ", ".join(f"{a.shape[0]}x{a.shape[1]} in [{float(a.min()):.4g}, "
                          f"{float(a.max()):.4g}]" if a.size else f"{a.shape}"
                          for a in self.images)
        noise = ("" if self.noise is None else
                 f", noise photons {self.noise['photons']:g}, read noise "
                 f"{self.noise['read_noise']:g}")
        colour = "" if self.cfa is None else f", cfa {_cfa.describe(self.cfa)}"
        fall = "" if self.falloff is None else f", falloff {self.falloff}"
        return f"Raw({len(self.images)} channel(s): {chans}{noise}{colour}{fall})"

    def channel(self, i: int) -> np.ndarray:
        """Channel ``i``'s raw (channels numbered from 1)."""
        n = len(self.images)
        c = _validate.integer(i, "channel", f"an integer in [1, {n}]")
        if not 1 <= c <= n:
            raise InvalidParameter.of("channel", c, f"an integer in [1, {n}]")
        return self.images[c - 1]

    def grey(self) -> Raw:
        """The grey raw of a mosaiced one (docs/model.md §12): each pixel divided by its
        colour's quantum efficiency (the core's ``cfa_grey``), exact for a grey scene; a
        grey raw is itself. Its noise: photons N q when the three QEs are q (a pixel's
        photo-electrons are N q value), else not stated (None: the colours' noise
        differs)."""
        cfa = self.cfa
        if cfa is None:
            return self
        images = tuple(_cfa.grey(a, cfa) for a in self.images)
        noise = self.noise
        qe = cfa["qe"]
        if noise is not None and len(set(qe)) == 1:
            noise = {"photons": noise["photons"] * qe[0], "read_noise": noise["read_noise"]}
        elif noise is not None and noise["photons"] != math.inf:
            noise = None
        return Raw._adopt(self.design, images, noise, None, self.falloff)

    def save(self, path: str | os.PathLike[str], *, force: bool = True) -> None:
        """Write the raw file (module docstring: an ``.npz`` with ``format``, ``design``
        and ``channel1``, ...) atomically: a temporary file in the same folder, renamed
        onto ``path`` when complete, so an error or Ctrl-C leaves no partial file.
        ``force=False`` refuses an existing ``path`` (``FileExistsError``)."""
        arrays: dict[str, Any] = {"format": np.array(FORMAT),
                                  "design": np.array(self.design.design.to_toml())}
        arrays.update({f"channel{i}": a for i, a in enumerate(self.images, 1)})
        if self.noise is not None:
            arrays["noise"] = np.array([self.noise["photons"], self.noise["read_noise"]])
        if self.cfa is not None:
            arrays["cfa"] = np.array(self.cfa["pattern"])
            arrays["qe"] = np.array(self.cfa["qe"], dtype=np.float64)
        if self.falloff is not None:
            arrays["falloff"] = np.array(self.falloff)
        with atomic_output(path, force=force) as tmp, open(tmp, "wb") as fh:
            np.savez(fh, **arrays)

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> Raw:
        """Read a raw file written by :meth:`save` (exact round trip). Raises
        ``FileNotFoundError`` (no such file) and ``ValueError`` naming ``path`` and what is
        wrong for anything that is not such a file."""
        name = os.fspath(path)
        if os.path.isdir(name):
            raise ValueError(f"{name}: a folder, not a splitlf raw file")
        try:
            npz = np.load(name, allow_pickle=False)
        except FileNotFoundError:
            raise
        except (OSError, ValueError, EOFError, zipfile.BadZipFile) as e:
            raise ValueError(f"{name}: not a splitlf raw file (not a NumPy .npz archive: "
                             f"{e})") from None
        if not isinstance(npz, np.lib.npyio.NpzFile):
            raise ValueError(f"{name}: not a splitlf raw file (a .npy array, not an .npz "
                             "archive)")
        with npz:
            try:
                return _read_raw(name, npz)
            except (ValueError, TypeError, KeyError, zipfile.BadZipFile) as e:
                msg = str(e)
                raise ValueError(msg if msg.startswith(name) else f"{name}: {msg}") from None


def _read_raw(name: str, npz: Any) -> Raw:
    keys = set(npz.files)
    if "format" not in keys or npz["format"].shape != () or str(npz["format"]) != FORMAT:
        raise ValueError(f"not a splitlf raw file (needs format = {FORMAT!r})")
    if "design" not in keys or npz["design"].dtype.kind != "U" or npz["design"].shape != ():
        raise ValueError("no design TOML text (key 'design')")
    design = _design_from_text(name, str(npz["design"]))
    channels = [f"channel{i}" for i in range(1, len(design.channels) + 1)]
    extra = sorted(keys - {"format", "design", "noise", "cfa", "qe", "falloff", *channels})
    missing = [c for c in channels if c not in keys]
    if missing or extra:
        raise ValueError(f"the arrays {sorted(keys - {'format', 'design'})} do not match "
                         f"the design's {len(channels)} channel(s) ({', '.join(channels)})")
    shapes = _expected_shapes(design)
    _check_headers(npz, channels, shapes)
    check_raws_fit(shapes, "its raws", "Raw.load")
    noise = None
    if "noise" in keys:
        v = npz["noise"]
        if v.shape != (2,) or v.dtype.kind != "f":
            raise ValueError(f"the noise model (key 'noise') has shape {v.shape} and dtype "
                             f"{v.dtype}: needs 2 floats, [photons, read_noise]")
        noise = {"photons": float(v[0]), "read_noise": float(v[1])}
    falloff = None
    if "falloff" in keys:
        v = npz["falloff"]
        if v.shape != () or v.dtype.kind != "U" or str(v) not in FALLOFFS:
            raise ValueError(f"the falloff (key 'falloff') is {v!r}: needs one of "
                             f"{', '.join(map(repr, FALLOFFS))}")
        falloff = str(v)
    return Raw._adopt(design, tuple(npz[c] for c in channels), noise, _read_cfa(npz, keys),
                      falloff)


def _read_cfa(npz: Any, keys: set[str]) -> dict[str, Any] | None:
    """The raw's colour filter array (keys ``cfa`` and ``qe``; neither: a grey raw)."""
    if "cfa" not in keys:
        if "qe" in keys:
            raise ValueError("a quantum efficiency (key 'qe') without a cfa")
        return None
    p = npz["cfa"]
    if p.dtype.kind != "U" or p.shape != ():
        raise ValueError(f"the cfa (key 'cfa') has shape {p.shape} and dtype {p.dtype}: "
                         "needs a pattern's name")
    qe = None
    if "qe" in keys:
        v = npz["qe"]
        if v.shape != (3,) or v.dtype.kind != "f":
            raise ValueError(f"the quantum efficiencies (key 'qe') have shape {v.shape} and "
                             f"dtype {v.dtype}: needs 3 floats")
        qe = [float(q) for q in v]
    return _cfa.options(str(p), qe)


def _check_headers(npz: Any, channels: list[str], shapes: list[tuple[int, int]]) -> None:
    """Each channel's declared shape and dtype from its .npy header, read before any
    array is (a file declaring a huge array must not make the reader allocate it)."""
    for i, (name, shape) in enumerate(zip(channels, shapes, strict=True)):
        with npz.zip.open(f"{name}.npy") as fh:
            version = np.lib.format.read_magic(fh)
            if version == (1, 0):
                declared, _, dtype = np.lib.format.read_array_header_1_0(fh)
            elif version == (2, 0):
                declared, _, dtype = np.lib.format.read_array_header_2_0(fh)
            else:
                raise ValueError(f"{name}: an .npy format version {version} not written by "
                                 "Raw.save")
        if tuple(declared) != shape:
            raise ValueError(f"invalid images[{i}] ({name}): declares shape "
                             f"{tuple(declared)}, allowed {shape} (channel {i + 1}'s raw, "
                             "docs/model.md §10)")
        if dtype.kind not in "fiuO" or dtype.itemsize > 8:  # (objects: the loader refuses)
            raise ValueError(f"invalid images[{i}] ({name}): declares dtype {dtype}, "
                             "allowed real numbers")


def _design_from_text(name: str, text: str) -> Design:
    if sys.version_info >= (3, 11):
        import tomllib
    else:  # pragma: no cover - Python 3.10 (the tomli backport)
        import tomli as tomllib
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise ValueError(f"its design is not valid TOML: {e}") from None
    if set(doc) != {"design"} or not isinstance(doc["design"], dict):
        raise ValueError("its design TOML needs exactly one [design] table")
    return Design.from_dict(doc["design"], source=f"{name}: design")


# -- render ------------------------------------------------------------------------------------

def _bbox(a: Extent, b: Extent) -> Extent:
    return min(a[0], b[0]), max(a[1], b[1]), min(a[2], b[2]), max(a[3], b[3])


def _view(core: Any, zlo: float, zhi: float) -> Extent:
    """What the pixels see over depths [zlo, zhi]: a ray's lateral position is affine in
    its depth (docs/model.md §10), so the box of the two end planes' extents holds it."""
    ext: Any = _native.render_extent
    a, b = (tuple(float(v) for v in ext(core, z)) for z in (zlo, zhi))
    return min(a[0], b[0]), max(a[1], b[1]), min(a[2], b[2]), max(a[3], b[3])


def _random_extent(design: Design, surface: Plane | DepthMap) -> Extent:
    """The region a random texture covers: what the pixels see over the scene's depths."""
    core, near = design.core, design.F * (1 + 1e-9)
    if isinstance(surface, DepthMap):
        box = _view(core, float(surface.depth.min()), float(surface.depth.max()))
        x0, x1, y0, y1 = surface.extent
        clipped = (max(box[0], x0), min(box[1], x1), max(box[2], y0), min(box[3], y1))
        return clipped if clipped[0] < clipped[1] and clipped[2] < clipped[3] else box
    box = _view(core, surface.z0, surface.z0)
    cap = RANDOM_DEPTH_FACTOR * surface.z0
    for _ in range(_EXTENT_ROUNDS):  # the plane's depths in view, to a fixed point
        lo, hi = surface.depths(box)
        grown = _bbox(box, _view(core, min(max(lo, near), cap), min(max(hi, near), cap)))
        if grown == box:
            break
        box = grown
    return box


def _texture_seam(scene: Scene, design: Design, rng: np.random.Generator
                  ) -> tuple[str, list[float], np.ndarray | None]:
    tex = scene.texture
    if isinstance(tex, RandomAlbedo):
        step = design.resolution_step(scene.reference_depth())
        return tex.seam(_random_extent(design, scene.depth), step, rng)
    kind, params, image = tex.seam()
    return kind, params, image


def scene_parts(scene: Scene, design: Design, rng: np.random.Generator) -> ScenePart:
    """The core's scene for a render of ``design`` as plain values (a random albedo drawn
    from ``rng``): the arguments of ``_native.RenderScene``, which a render's tasks carry."""
    kind, params, image = _texture_seam(scene, design, rng)
    surface, sparams, depth_map = scene.depth.seam()
    background = scene.background
    assert background is not None  # Scene.__post_init__ sets it
    return kind, params, image, surface, sparams, depth_map, background


def native_scene(scene: Scene, design: Design, rng: np.random.Generator
                 ) -> _native.RenderScene:
    """The core's scene for a render of ``design`` (a random albedo drawn from ``rng``)."""
    return _native.RenderScene(*scene_parts(scene, design, rng))


FALLOFFS = ("microlens", "main", "both")
"""The radiometric falloffs :func:`render` takes besides None (docs/model.md §10)."""


def falloff_option(falloff: Any) -> str | None:
    """``falloff`` checked: None (off) or one of :data:`FALLOFFS` (``TypeError`` for a
    value that is not a string, :class:`~splitlf.errors.InvalidParameter` naming
    ``falloff`` for an unknown one)."""
    if falloff is None:
        return None
    allowed = "None, " + ", ".join(map(repr, FALLOFFS))
    if not isinstance(falloff, str):
        raise TypeError(f"falloff must be {allowed}, got {type(falloff).__name__}")
    if falloff not in FALLOFFS:
        raise InvalidParameter.of("falloff", falloff, allowed)
    return falloff


def _target(tol: Any, noise_tol: Any, noise: dict[str, float] | None
            ) -> float | tuple[float, float, float]:
    """The core's error target: ``tol`` (default ``_native.RENDER_TOL``), or (photons,
    read noise, fraction) for ``noise_tol``."""
    if noise_tol is None:
        return _native.RENDER_TOL if tol is None else _validate.real(tol, "tol")
    if tol is not None:
        raise ValueError("give tol or noise_tol, not both: noise_tol sets each pixel's "
                         "target from the noise")
    fraction = _validate.positive(noise_tol, "noise_tol", 1.0)
    if noise is None:
        raise ValueError("noise_tol is a fraction of the render's noise: it needs "
                         "noise={'photons': N} (N finite)")
    return (noise["photons"], noise["read_noise"], fraction)


def render(design: Design, scene: Scene, *, noise: Mapping[str, float] | None = None,
           seed: int | None = 0, tol: float | None = None, noise_tol: float | None = None,
           n_threads: int | None = None, progress: bool | None = None,
           executor: cf.Executor | None = None, rows_per_task: int | None = None,
           cfa: str | None = None, qe: Sequence[float] | None = None,
           falloff: str | None = None) -> Raw:
    """Each channel's raw sensor image of ``scene`` (docs/model.md §10), computed in the
    core.

    - ``design``: a :class:`~splitlf.Design` (any of §9: rect or hex grids, lens types,
      square or circular aperture, ideal or sensor layout; a :class:`~splitlf.Camera` is
      one)
    - ``scene``: a :class:`Scene`; a :class:`~splitlf.RandomAlbedo` texture is drawn on
      cells covering everything the pixels see (``_native.render_extent`` over the
      scene's depths)
    - ``noise``: None (noise-free: the raw records ``{"photons": inf, "read_noise": 0}``)
      or ``{"photons": N, "read_noise": r}`` (recorded on the raw, ``Raw.noise``) as in
      :func:`~splitlf.simulate`: counts Poisson(N value) plus Gaussian read noise of r
      electrons rms, divided by N (N finite in (0, 1e15], r finite >= 0)
    - ``seed``: an integer >= 0 (or None: fresh entropy); the texture is drawn by
      ``np.random.default_rng([seed, 0])``, the noise by ``np.random.default_rng([seed,
      1])``, channel 1 first: a given seed gives the same raw bit for bit
    - ``tol``: the error target of a pixel, relative to a fully lit pixel under the
      scene's largest albedo (None: ``_native.RENDER_TOL``, 1e-3; allowed [1e-10, 0.1];
      docs/render.md); the exact route
      (rect grid, square aperture, ideal layout, fronto-parallel plane; an image, constant,
      sinusoid or bar texture) has no quadrature error at all (docs/render.md)
    - ``noise_tol``: instead of ``tol``, an error target relative to the noise this render
      adds: each pixel's target is ``noise_tol`` (in (0, 1], e.g. 0.1) times the standard
      deviation of ``noise`` at the pixel's own value v, sqrt(max(v, 1/N)/N + (r/N)^2) (a
      value under one photon counted as one), held within the range ``tol`` accepts;
      needs ``noise`` (docs/render.md, "A target relative to the noise")
    - ``n_threads``: threads of the core (None: all cores)
    - ``progress``: a tqdm bar on stderr (None: only when stderr is a terminal)
    - ``executor``: None (in-process) or a ``concurrent.futures.Executor`` (a thread or
      process pool, Dask's ``client.get_executor()``): each channel's raw rows are cut
      into bands of ``rows_per_task`` rows (None: the rows over 64 tasks), one task each
      on ``n_threads`` core threads (None: 1), and gathered; the raws are bit for bit the
      in-process render's (same seed: the texture is drawn once here, the noise added
      here after assembly; docs/render.md, "Scale-out and datasets"). ``rows_per_task``
      an integer >= 1, only with an executor
    - ``cfa``: None (a grey sensor) or a Bayer colour filter array on every channel's
      sensor, ``"RGGB"``, ``"GRBG"``, ``"GBRG"`` or ``"BGGR"`` (docs/model.md §12): the
      scene is rendered once per colour (noise-free; once for a grey texture, the same
      in every colour), each channel's raws mosaiced in the core (a pixel in raw row r,
      column c takes colour P[r % 2][c % 2] of the pattern P, times that colour's QE),
      and the noise added after: a pixel's photo-electrons are N QE value, N those of a
      white full-aperture pixel of QE 1. A colour texture needs a ``cfa``. With
      ``noise_tol`` each render's target is set from the noise of QE 1 (the mosaic's
      own, N QE, is larger relative to QE value: the target is at least as tight)
    - ``qe``: the quantum efficiencies (red, green, blue), each in (0, 1] (None: 1, 1,
      1); only with a ``cfa``
    - ``falloff``: None (off, the default: the paper's paraxial model) or radiometric
      falloff, each ray weighted by the cos^4 law on its microlens-to-sensor segment
      (``"microlens"``), its main-lens-to-array segment (``"main"``) or both (``"both"``),
      so that a white raw is brightest at each micro-image's centre as a real camera's
      (docs/model.md §10, "Radiometric falloff"); recorded on the raw (``Raw.falloff``).
      With falloff every channel takes the general route (docs/render.md)

    Returns a :class:`Raw` (its ``cfa`` and ``falloff`` recorded). Raises ``TypeError`` and
    :class:`~splitlf.errors.InvalidParameter` (checked before any work; the core adds a
    surface at or behind the main lens's focal plane where a pixel sees it),
    :class:`~splitlf.errors.TooLargeError` (up front, saying how much memory it needs)
    and ``KeyboardInterrupt`` (Ctrl-C stops the core within a second; with an executor,
    the tasks not started are cancelled).
    """
    subject = _validate.design(design)
    if not isinstance(scene, Scene):
        raise TypeError(f"scene must be a splitlf.Scene, got {type(scene).__name__}")
    noise_ = _noise(noise)
    seed_ = _seed(seed)
    threads = _validate.n_threads(n_threads)
    target = _target(tol, noise_tol, noise_)
    falloff_ = falloff_option(falloff)
    show = _progress_flag(progress)
    fresh: Any = np.random.SeedSequence().entropy  # an int for a fresh SeedSequence
    entropy = int(fresh) if seed_ is None else seed_
    executor, rows_per_task, threads = check_options(executor, rows_per_task, threads)
    cfa_ = _cfa.options(cfa, qe)
    if cfa_ is None and scene.is_colour:
        raise InvalidParameter.of("cfa", None, "a Bayer pattern (one of "
                                  f"{', '.join(_cfa.PATTERNS)}) for a colour texture")
    texture_rng = np.random.default_rng([entropy, 0])
    noise_rng = np.random.default_rng([entropy, 1])

    def once(part: Scene) -> list[np.ndarray]:
        return _render_parts(subject, scene_parts(part, subject, texture_rng), target,
                             threads, (executor, rows_per_task), show, falloff_)

    if cfa_ is None:
        images = once(scene)
    else:  # one render per colour (one for a grey scene), mosaiced per channel
        planes = [once(scene.colour(k)) for k in range(3)] if scene.is_colour else (
            [once(scene)] * 3)
        images = [_cfa.mosaic(rgb, cfa_) for rgb in zip(*planes, strict=True)]
        del planes
    for i, a in enumerate(images):  # in place: one channel's noise draws at a time
        images[i] = _add_noise(np.asarray(a), noise_, noise_rng)
    return Raw._adopt(subject, tuple(images), dict(NOISE_FREE) if noise_ is None else noise_,
                      cfa_, falloff_)


def _render_parts(subject: Design, parts: ScenePart, target: Any, threads: int | None,
                  scale: tuple[cf.Executor | None, int | None], show: Any,
                  falloff: str | None) -> list[np.ndarray]:
    """Each channel's noise-free raw of the scene ``parts``: in bands on ``scale``'s
    executor, or in-process with a progress bar."""
    executor, rows_per_task = scale
    if executor is not None:
        return list(render_bands(executor, subject, _expected_shapes(subject), parts, target,
                                 threads, rows_per_task, show, falloff))
    bar, callback = _progress(show)
    try:
        return list(_native.render(subject.core, _native.RenderScene(*parts), tol=target,
                                   n_threads=threads, progress=callback,
                                   falloff=falloff))
    finally:
        if bar is not None:
            bar.close()
