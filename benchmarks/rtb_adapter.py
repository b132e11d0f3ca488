"""The Robotics Toolbox for Python (optional): a DHRobot built from a manipdyn arm.

Installed by the ``bench`` extra (``pip install -e '.[bench]'``).  Everything
here degrades to a clear "skipped" reason when the Toolbox is missing.

The DHRobot is built from the *same* numbers as the manipdyn arm (DH
parameters, mass, centre of mass, inertia tensor about the centre of mass in
DH frame i), with ``Jm = 0, B = 0, Tc = 0, G = 1``: rigid-body dynamics only.
Offsets: manipdyn's revolute ``theta`` and prismatic ``d`` are the Toolbox's
``offset`` (added to the joint variable).
"""

from __future__ import annotations

import numpy as np

_RTB = None
_REASON = None


def toolbox():
    """``(module, None)`` or ``(None, reason)``."""
    global _RTB, _REASON
    if _RTB is None and _REASON is None:
        try:
            import warnings

            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                import roboticstoolbox as rtb
            _RTB = rtb
        except Exception as exc:  # ImportError, or a broken install
            _REASON = (f"roboticstoolbox-python is not importable ({type(exc).__name__}: {exc}); "
                       "install the bench extra: pip install -e '.[bench]'")
    return _RTB, _REASON


def version():
    rtb, _ = toolbox()
    return getattr(rtb, "__version__", "?") if rtb else None


def dhrobot(arm):
    """A ``roboticstoolbox.DHRobot`` with the arm's DH table and rigid-body data."""
    rtb, reason = toolbox()
    if rtb is None:
        raise RuntimeError(reason)
    modified = arm.convention == "modified"
    links = []
    for l in arm.links:
        kw = dict(a=l.a, alpha=l.alpha, m=l.mass, r=np.array(l.com, dtype=float),
                  I=np.array(l.inertia, dtype=float), Jm=0.0, B=0.0, Tc=[0.0, 0.0], G=1.0)
        if l.qlim is not None:
            kw["qlim"] = np.array(l.qlim)
        if l.joint == "revolute":
            cls = rtb.RevoluteMDH if modified else rtb.RevoluteDH
            links.append(cls(d=l.d, offset=l.theta, **kw))
        else:
            cls = rtb.PrismaticMDH if modified else rtb.PrismaticDH
            links.append(cls(theta=l.theta, offset=l.d, **kw))
    return rtb.DHRobot(links, gravity=np.array(arm.gravity, dtype=float), name=arm.name or "arm")


def calls(robot):
    """The five operations as callables on one state, named like manipdyn's."""
    n = robot.n
    zeros = np.zeros(n)
    g0 = np.zeros(3)
    return {
        "mass_matrix": lambda q: robot.inertia(q),
        # h(q, qd) = rne with zero gravity and zero acceleration (one C call)
        "coriolis_torque": lambda q, qd: robot.rne(q, qd, zeros, gravity=g0),
        "gravity_torque": lambda q: robot.gravload(q),
        "inverse_dynamics": lambda q, qd, qdd: robot.rne(q, qd, qdd),
        "forward_dynamics": lambda q, qd, tau: robot.accel(q, qd, tau),
    }


def coriolis_matrix_route(robot):
    """h via the Coriolis matrix, ``coriolis(q, qd) @ qd`` (the Toolbox's other route)."""
    return lambda q, qd: robot.coriolis(q, qd) @ qd


def rne_python(robot):
    """The Toolbox's pure-Python RNE (its reference when the C extension is in doubt)."""
    return lambda q, qd, qdd: robot.rne_python(q, qd, qdd)


#: Toolbox models to compare parameter by parameter with manipdyn's bundled data
_MODELS = {"puma560": "Puma560", "stanford": "Stanford", "ur5": "UR5", "ur10": "UR10"}


def bundled_model_differences(arm):
    """Differences between the Toolbox's own model of this arm and manipdyn's numbers.

    Returns ``None`` if the Toolbox has no such model, else a list of strings
    (empty if every DH, mass, centre-of-mass and inertia number matches).
    """
    rtb, _ = toolbox()
    cls = _MODELS.get(arm.name)
    if rtb is None or cls is None or not hasattr(rtb.models.DH, cls):
        return None
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ref = getattr(rtb.models.DH, cls)()
    out = []
    if len(ref.links) != arm.n:
        return [f"{len(ref.links)} links in the Toolbox model vs {arm.n}"]
    if bool(ref.mdh) != (arm.convention == "modified"):
        out.append("DH convention differs")
    for i, (l, L) in enumerate(zip(arm.links, ref.links), start=1):
        if l.joint == "revolute":
            pairs = [("a", l.a, L.a), ("alpha", l.alpha, L.alpha), ("d", l.d, L.d), ("theta offset", l.theta, L.offset)]
        else:
            pairs = [("a", l.a, L.a), ("alpha", l.alpha, L.alpha), ("theta", l.theta, L.theta), ("d offset", l.d, L.offset)]
        pairs += [("m", l.mass, L.m)]
        for what, mine, theirs in pairs:
            if not np.isclose(float(mine), float(theirs), rtol=1e-9, atol=1e-12):
                out.append(f"link {i} {what}: manipdyn {float(mine):g}, Toolbox {float(theirs):g}")
        if not np.allclose(np.asarray(l.com, float), np.asarray(L.r, float).ravel(), rtol=1e-9, atol=1e-12):
            out.append(f"link {i} centre of mass: manipdyn {np.asarray(l.com).tolist()}, Toolbox {np.asarray(L.r).ravel().tolist()}")
        Im, It = np.asarray(l.inertia, float), np.asarray(L.I, float)
        if not np.allclose(Im, It, rtol=1e-9, atol=1e-12):
            out.append(f"link {i} inertia differs (max |difference| {np.abs(Im - It).max():.3g} kg m^2)")
    return out
