"""Rigs: ffdkit.Rig, a recorded deformation (JSON rig or PyGeM .prm)."""
from __future__ import annotations

import json
import os
from typing import Any, Mapping, Optional, Union

import numpy as np

from . import _ffd

Source = Union[str, "os.PathLike[str]", Mapping[str, Any]]


def _decode_report(r: dict) -> dict:
    r["details"] = json.loads(r["details"]) if r.get("details") else {}
    r["notes"] = r["notes"].splitlines() if r.get("notes") else []
    return r


class Rig(_ffd.Rig):
    """A recorded deformation: a JSON rig (docs/rig.md) or PyGeM .prm parameters.

    Made by :meth:`Rig.load`. ``rig.method`` names the method ('lattice',
    'pbffd', 'gffd', 'tspline', 'cage').
    """

    @classmethod
    def load(cls, source: Source, name: Optional[str] = None) -> "Rig":
        """Loads a rig from a path (.prm: PyGeM parameters; JSON otherwise), a
        dict (a rig as JSON) or JSON text (a str starting with '{').

        name names a dict or text in error messages, and files the rig refers
        to are resolved against its directory (default: the current one).
        Raises ParseError naming the file, line or key; FileError for a
        missing file.
        """
        if isinstance(source, Mapping):
            text = json.dumps(source, allow_nan=False)
            return cls._parse_json(text, name or "<dict>")
        if isinstance(source, str) and source.lstrip().startswith("{"):
            return cls._parse_json(source, name or "<string>")
        if isinstance(source, (str, os.PathLike)):
            return cls._read(source)
        if isinstance(source, (bytes, bytearray)):
            raise TypeError("source: expected a path, a dict or JSON text (str), got bytes")
        raise TypeError(f"source: expected a path, a dict or JSON text, got {type(source).__name__}")

    def apply(self, target: Any, out: Optional[np.ndarray] = None,
              limits: Optional[Mapping[str, Any]] = None) -> Any:
        """Applies the rig (the GIL released), exactly as ``ffd deform``.

        target (N, 3) points: returns the deformed points, a new array or out
        (C-contiguous float64 (N, 3), written in place). target a Mesh: deforms
        it in place and returns the report as a dict (method, residuals,
        reached, rank, max_residual, outside_count, timings, control_points,
        resolution, notes, details). limits: {"max_memory", "max_work",
        "unlimited"} (ffd_limits; None: the defaults).
        """
        if isinstance(target, _ffd.Mesh):
            return _decode_report(self._apply(target, out, limits))
        return self._apply(target, out, limits)

    def deformer(self, target: Any, limits: Optional[Mapping[str, Any]] = None):
        """The rig's deformer for target (a Mesh or (N, 3) points): the same as
        ``ffdkit.Deformer(rig, target, limits)``, an instance of the method's
        Deformer subclass."""
        from ._deformer import Deformer

        return Deformer(self, target, limits)

    def __repr__(self) -> str:
        return f"<ffdkit.Rig {self.method} {self.name!r}>"
