"""Which header names hold which signal of a measurement log.

Layer 2 (formats: logs).

A log's columns are found by name through a mapping from a *signal* to a
header *pattern*, ``{i}`` standing for the joint number (1 to n) and
``{i0}`` for the joint index (0 to n - 1).  The defaults are manipdyn's
own names; :func:`column_map` overrides some of them, from a dict or from
the command-line form ``"q=Joint_{i},tau=Effort_{i}"``.

=========  ===========  ===============================================
signal     default      what (SI units unless ``deg``)
=========  ===========  ===============================================
``t``      ``t``        time stamp, s (may be absent: give ``rate``)
``q``      ``q{i}``     joint position, rad or m
``qd``     ``qd{i}``    joint velocity (optional)
``qdd``    ``qdd{i}``   joint acceleration (optional)
``tau``    ``tau{i}``   joint torque or force, N m or N
``qm``     ``qm{i}``    motor position, rad at the motor
``qdm``    ``qdm{i}``   motor velocity, rad/s at the motor (optional)
``taum``   ``taum{i}``  motor torque, N m at the motor
``i``      ``i{i}``     motor current, A (times the torque constant)
=========  ===========  ===============================================

A position comes from ``q`` or ``qm``, a torque from ``tau``, ``taum`` or
``i``: exactly one of each must be present in full (all n columns).
"""

from __future__ import annotations

from collections.abc import Mapping

from ..._support.errors import ModelError

__all__ = ["DEFAULTS", "SIGNALS", "ColumnMap", "column_map"]

#: default header pattern of every signal
DEFAULTS = {"t": "t", "q": "q{i}", "qd": "qd{i}", "qdd": "qdd{i}", "tau": "tau{i}",
            "qm": "qm{i}", "qdm": "qdm{i}", "taum": "taum{i}", "i": "i{i}"}
SIGNALS = tuple(DEFAULTS)
_POSITIONS, _TORQUES = ("q", "qm"), ("tau", "taum", "i")


class ColumnMap:
    """Header patterns of each signal (module docstring); ``patterns`` is a dict."""

    def __init__(self, patterns: Mapping[str, str]):
        self.patterns = dict(patterns)

    def names(self, signal: str, n: int) -> list[str]:
        """The n header names of ``signal`` (one name for ``t``)."""
        pat = self.patterns[signal]
        if signal == "t":
            return [pat]
        return [pat.replace("{i0}", str(j)).replace("{i}", str(j + 1)) for j in range(n)]

    def resolve(self, header, n: int, where: str, extra_joints: bool = False):
        """``(index, unused)``: ``index[signal]`` is the list of column numbers of each
        signal found in ``header`` (``t`` is a one-element list), ``unused`` the
        header names no signal claims.  Raises :class:`ModelError` when a signal is
        present in part, when no (or more than one) position or torque signal is, or,
        unless ``extra_joints``, when a signal has a column for joint ``n + 1`` (the
        log has more joints than the model: a silent fit of the first n would be wrong).
        """
        pos = {h: k for k, h in enumerate(header)}
        index, partial = {}, []
        for s in SIGNALS:
            names = self.names(s, n)
            found = [x for x in names if x in pos]
            if len(found) == len(names):
                index[s] = [pos[x] for x in names]
            elif found:
                partial.append((s, [x for x in names if x not in pos]))
        twice = {}
        for s, ks in index.items():
            for k in ks:
                twice.setdefault(k, []).append(s)
        clash = next(((k, sigs) for k, sigs in twice.items() if len(sigs) > 1), None)
        if clash:
            raise ModelError(f"{where}: column {header[clash[0]]!r} is mapped to {' and '.join(clash[1])}; "
                             "each column is one signal (check columns=, --columns)")
        if partial:
            required = [x for s, names in partial if s in _POSITIONS + _TORQUES for x in names]
            optional = [x for s, names in partial if s not in _POSITIONS + _TORQUES for x in names]
            first = required or optional
            also = f"; the optional {optional} too" if required and optional else ""
            raise ModelError(f"{where}: missing column(s) {first} for an arm of {n} joints (the other columns "
                             f"of those signals are there){also}; {self._expected(n)}")
        for group, what in ((_POSITIONS, "position"), (_TORQUES, "torque")):
            have = [s for s in group if s in index]
            if not have:
                missing = [x for x in self.names(group[0], n) if x not in pos]
                raise ModelError(f"{where}: missing column(s) {missing}: no joint {what} columns "
                                 f"({' or '.join(self.patterns[s] for s in group)}); {self._expected(n)}")
            if len(have) > 1:
                raise ModelError(f"{where}: both {' and '.join(self.patterns[s] for s in have)} columns: "
                                 f"which is the {what}? map the other one away, e.g. columns='{have[1]}=unused{{i}}'")
        claimed = {k for ks in index.values() for k in ks}
        unused = [h for k, h in enumerate(header) if k not in claimed]
        nxt = {sig: self.names(sig, n + 1)[n] for sig in index if sig != "t"}   # joint n + 1's column
        beyond = [name for name in nxt.values() if name in pos]
        if beyond and not extra_joints:
            raise ModelError(f"{where}: column(s) {beyond} belong to joint {n + 1}, but the model has {n} joints: "
                             "a log of another arm, or a chain cut short (--tip)? Fitting n joints of a log "
                             "whose other joints moved gives a wrong model; if those columns are not joints of "
                             "this arm (a gripper), allow them with extra_joints=True (--extra-joints)")
        return index, unused

    def _expected(self, n: int) -> str:
        p = self.patterns
        q, tau = (x.replace("{i0}", "0").replace("{i}", "1") for x in (p["q"], p["tau"]))
        qn, taun = (x.replace("{i0}", str(n - 1)).replace("{i}", str(n)) for x in (p["q"], p["tau"]))
        return (f"expected a header {p['t']},{q}..{qn},{tau}..{taun} (optionally velocities and "
                f"accelerations, or motor-side columns; see manipdyn.formats.logs.columns)")


def column_map(columns=None, where: str = "columns") -> ColumnMap:
    """A :class:`ColumnMap` from ``None`` (the defaults), a mapping ``{signal: pattern}``
    or a string ``"signal=pattern,signal=pattern"``; the patterns given replace
    the defaults of their signals.  Raises :class:`ModelError` for an unknown
    signal, a malformed item or a per-joint pattern without ``{i}`` or ``{i0}``.
    """
    if isinstance(columns, ColumnMap):
        return columns
    items: dict[str, str] = {}
    if columns is None:
        pass
    elif isinstance(columns, str):
        for part in filter(None, (p.strip() for p in columns.split(","))):
            key, eq, value = part.partition("=")
            if not eq or not key.strip() or not value.strip():
                raise ModelError(f"{where}: expected items signal=pattern separated by commas, e.g. "
                                 f"'q=Joint_{{i}},tau=Effort_{{i}}'; got {part!r}")
            if key.strip() in items:        # the later one would silently win
                raise ModelError(f"{where}: signal {key.strip()!r} given twice ({items[key.strip()]!r} and "
                                 f"{value.strip()!r}); give each signal once")
            items[key.strip()] = value.strip()
    elif isinstance(columns, Mapping):
        items = {str(k): str(v) for k, v in columns.items()}
    else:
        raise ModelError(f"{where}: expected a mapping or a string 'signal=pattern,...', got "
                         f"{type(columns).__name__}")
    patterns = dict(DEFAULTS)
    for key, value in items.items():
        if key not in DEFAULTS:
            raise ModelError(f"{where}: unknown signal {key!r}; expected one of {', '.join(SIGNALS)}")
        if key != "t" and "{i}" not in value and "{i0}" not in value:
            raise ModelError(f"{where}: the pattern of {key!r} must contain {{i}} (joint number 1..n) or "
                             f"{{i0}} (0..n-1), got {value!r}")
        patterns[key] = value
    return ColumnMap(patterns)
