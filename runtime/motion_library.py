"""Serve a motion library to a controller: numpy and h5py only, for the robot's computer.

:class:`MotionLibrary` opens a file and finds entries by key, speed and stride count, or blends
two; an :class:`~skatelib.runtime.entry.Entry` samples one trajectory.
"""

from __future__ import annotations

import functools
from collections.abc import Iterator
from pathlib import Path

from skatelib.library import schema
from skatelib.library.certificate import Certificate
from skatelib.library.errors import LibraryFormatError, SkatelibError
from skatelib.library.model import HumanoidModel, QuadrupedModel
from skatelib.library.model_io import read_humanoid_model, read_quadruped_model
from skatelib.library.reader import EntryRecord, LibraryData, read_library
from skatelib.runtime.blend import DEFAULT_MARGIN, BlendMargin, MarginCheck, check_blend
from skatelib.runtime.blended import blend_pair
from skatelib.runtime.certified import usable
from skatelib.runtime.entry import Entry, EntryNotFound
from skatelib.runtime.references import real
from skatelib.runtime.renamed import renamed
from skatelib.runtime.routes import route, speed_key
from skatelib.runtime.selection import bracket, candidates


class MotionLibrary:
    """A motion library loaded into memory (``MotionLibrary.open(path)``).

    ``key in lib``, ``lib[key]``, ``lib.keys()`` and ``len(lib)`` work on entry keys; iterating
    yields the :class:`Entry` objects in file order (strides, then speed). Speeds go by one name
    each (``target_velocity_mps``, ``from_velocity_mps``); the old keywords raise a TypeError naming them.
    """

    def __init__(self, data: LibraryData):
        if not isinstance(data, LibraryData):
            raise TypeError(f"MotionLibrary(data) takes what read_library returns; open a file with "
                            f"MotionLibrary.open(path), got {data!r}")
        self.path, self.attrs = data.path, data.attrs
        self.model, self.model_arrays = data.model_attrs, data.model_arrays
        self.urdf = data.model_text.get(schema.D_ROBOT_URDF, "")
        self.content_sha256 = data.content_sha256  # the file's verified SHA-256 (format doc, Integrity)
        self._entries = {k: _entry(r) for k, r in data.entries.items()}

    @classmethod
    def open(cls, path: Path | str) -> MotionLibrary:
        """Load and verify a library file (see :func:`skatelib.library.reader.read_library`).

        Raises:
            LibraryFormatError: When the file is missing, corrupt, incomplete or of another major version.
        """
        return cls(read_library(path))

    @property
    def kind(self) -> str:
        return str(self.attrs[schema.A_KIND])

    @functools.cached_property
    def quadruped_model(self) -> QuadrupedModel:
        """The typed ``/model`` of a quadruped library (:mod:`skatelib.library.model`).

        Raises:
            LibraryFormatError: Not a quadruped library, or one without a required figure.
        """
        self._expect_kind("quadruped")
        try:
            return read_quadruped_model(self.model, self.model_arrays)
        except KeyError as e:
            raise self._missing(e) from e

    @functools.cached_property
    def humanoid_model(self) -> HumanoidModel:
        """The typed ``/model`` of a humanoid library (:mod:`skatelib.library.model`).

        Raises:
            LibraryFormatError: Not a humanoid library, or one without a required figure.
        """
        self._expect_kind("humanoid")
        try:
            return read_humanoid_model(self.model)
        except KeyError as e:
            raise self._missing(e) from e

    def _expect_kind(self, kind: str) -> None:
        if self.kind != kind:
            raise LibraryFormatError(self.path, f"/@{schema.A_KIND}", f"a {self.kind} library has no {kind} model")

    def _missing(self, e: KeyError) -> LibraryFormatError:
        return LibraryFormatError(self.path, f"/{schema.G_MODEL}/{e.args[0]}",
                                  "missing: the file is incomplete; rebuild it with skatelib build")

    def keys(self) -> list[str]:
        return list(self._entries)

    def __contains__(self, key: object) -> bool:
        return key in self._entries

    def __getitem__(self, key: str) -> Entry:
        """The entry named ``key``.

        Raises:
            EntryNotFound: Listing the keys that exist.
        """
        try:
            return self._entries[key].ready()
        except KeyError:
            raise EntryNotFound(f"{self.path}: no entry {key!r}; entries: {', '.join(self._entries)}") from None

    def __iter__(self) -> Iterator[Entry]:
        return iter(self._entries.values())

    def __len__(self) -> int:
        return len(self._entries)

    def __repr__(self) -> str:
        ok = sum(e.success for e in self)
        return (f"MotionLibrary({str(self.path)!r}, kind={self.kind!r}, {len(self)} entries, {ok} successful, "
                f"speeds {self.speeds()} m/s)")

    @renamed(v_from="from_velocity_mps")
    def speeds(self, strides: int | None = None, from_velocity_mps: float = 0.0) -> list[float]:
        """Target speeds of the successful entries from ``from_velocity_mps`` (0: the start-ups; with
        ``strides`` strides, when given) [m/s]."""
        return sorted({e.target_velocity_mps for e in self if e.success and speed_key(e.from_velocity_mps) ==
                       speed_key(from_velocity_mps) and (strides is None or e.n_strides == strides)})

    def start_speeds(self) -> list[float]:
        """The speeds successful entries start at: 0 (the start-ups) and the transitions' [m/s]."""
        return sorted({speed_key(e.from_velocity_mps) for e in self if e.success})

    @functools.cached_property
    def certificate(self) -> Certificate | None:
        """The robustness certificate (``skatelib certify``), or None."""
        text = self.attrs.get(schema.A_CERTIFICATE)
        return None if text is None else Certificate.from_json(str(text), f"{self.path}: /@{schema.A_CERTIFICATE}")

    @renamed(velocity="target_velocity_mps", v_from="from_velocity_mps", v_to="target_velocity_mps")
    def select(self, target_velocity_mps: float, strides: int | None = None, clamp: bool = False,
               from_velocity_mps: float = 0.0, min_success: float | None = None) -> Entry:
        """The successful entry from ``from_velocity_mps`` (0: a start-up from rest) nearest
        ``target_velocity_mps`` [m/s] (fewest strides on ties); with ``min_success``, only entries
        certified at that success rate or better (:mod:`skatelib.runtime.certified`).

        Raises:
            ValueError: When a speed is NaN or infinite, a transition's target is its start speed, or
                ``min_success`` is not from 0 to 1.
            EntryNotFound: When no (certified) successful entry starts at ``from_velocity_mps`` or has ``strides``
                strides, or ``target_velocity_mps`` lies outside the stored speeds and ``clamp`` is
                false (the message lists the speeds; :meth:`route` chains entries where no single one
                gets there).
        """
        v, v0 = target_velocity_mps, from_velocity_mps
        if not (real(v) and real(v0)):
            raise ValueError(f"select(target_velocity_mps, from_velocity_mps): finite speeds in m/s, got {v!r}, {v0!r}")
        if v0 and speed_key(v) == speed_key(v0):
            raise ValueError(f"select({v!r}, from_velocity_mps={v0!r}): a transition changes the speed")
        c, note = candidates(self, strides, v0, min_success)
        speeds = sorted({e.target_velocity_mps for e in c})
        if clamp:  # the nearest stored speed, also for a target so far out that differences round alike
            v = min(max(v, speeds[0]), speeds[-1])
        if not clamp and not speeds[0] - 1e-9 <= v <= speeds[-1] + 1e-9:
            which = "" if strides is None else f" for {strides} strides"
            start = "" if not v0 else f" from {v0} m/s"
            raise EntryNotFound(f"{self.path}: {v} m/s is outside the stored speeds{start} {speeds} m/s{which}; "
                                f"pass clamp=True for the nearest, or route() for a chain{note}")
        return min(c, key=lambda e: (abs(e.target_velocity_mps - v), e.n_strides)).ready()

    @renamed(v_from="from_velocity_mps", v_to="target_velocity_mps")
    def route(self, from_velocity_mps: float, target_velocity_mps: float,
              min_success: float | None = None) -> list[Entry]:
        """The chain of successful entries (certified at ``min_success`` or better, when given) that
        rides from ``from_velocity_mps`` to ``target_velocity_mps`` [m/s] in the least time (0: at
        rest; a single entry when no chain is quicker; :func:`skatelib.runtime.routes.route`).

        Raises:
            ValueError: When the speeds are equal or negative, or ``min_success`` is not from 0 to 1.
            EntryNotFound: When no chain gets there (the message lists what can be reached and the
                entries skipped below ``min_success``).
        """
        entries, note = usable(self, self.certificate if min_success is not None else None, min_success)
        try:
            return [e.ready() for e in route(entries, from_velocity_mps, target_velocity_mps, f"{self.path}: ")]
        except EntryNotFound as e:
            raise EntryNotFound(f"{e}{note}") from None

    @renamed(velocity="target_velocity_mps")
    def blend(self, target_velocity_mps: float, strides: int | None = None, strict: bool = True,
              margin: BlendMargin = DEFAULT_MARGIN) -> Entry:
        """Linear blend of the two successful start-ups (from rest) around ``target_velocity_mps``
        [m/s] with the same strides (the fewest whose start-ups bracket it when ``strides`` is None).

        Both entries share the contact schedule (same period and duty), so phases align knot by
        knot. The blend is checked against Coulomb cones and joint limits with ``margin``
        (``Entry.check``). Its attributes are its own: the blended speed, ``blend_sources`` and
        ``blend_weights``, and ``success`` only when both sources succeeded and the check passes.

        Raises:
            ValueError: When ``target_velocity_mps`` is NaN or infinite.
            TypeError: When ``margin`` is not a :class:`BlendMargin`.
            EntryNotFound: When no stride count's entries bracket ``target_velocity_mps``.
            SkatelibError: When ``strict`` and the blend misses the margins, or the library is not a
                quadruped's (a humanoid's entries are not blended).
        """
        v = target_velocity_mps
        if not real(v):
            raise ValueError(f"blend(target_velocity_mps): a finite speed in m/s, got {v!r}")
        check_blend(self.path, self.kind, margin)
        a, b = bracket(self, v, strides)
        lower, upper = (self.model_arrays.get(k) for k in (schema.D_JOINT_LOWER, schema.D_JOINT_UPPER))
        e = blend_pair(a, b, v, MarginCheck(float(self.model[schema.A_FRICTION_MU]), lower, upper, margin))
        if strict and e.check is not None and not e.check.ok:
            raise SkatelibError(f"blend at {v} m/s misses its margins: {e.check}")
        return e.ready()


def _entry(r: EntryRecord) -> Entry:
    return Entry(r.key, dict(r.attrs), dict(r.arrays), {k: tuple(v) for k, v in r.columns.items()},
                 {k: tuple(v) for k, v in r.units.items()})
