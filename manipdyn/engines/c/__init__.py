"""Generated C: the arm's dynamics as a dependency-free C99 file, and the third engine built from it.

Layer 3 (engines: c).  ``md.codegen(arm, dir, prefix=None)`` writes ``dir/P.h`` and
``dir/P.c`` (:mod:`.source`); ``arm.compiled`` (``arm.engine("c")``) is the
same C compiled and called through ctypes (:mod:`.engine`; one state through
bound buffers, :mod:`.fast`).  The recursive
algorithms are written as CasADi SX graphs (:mod:`.graph`) and emitted as
plain C by our own emitter (:mod:`.emit`); :mod:`.build` compiles and caches.
Shares no code with ``engines.lagrange`` or ``engines.pinocchio`` (the
independence contract).
May import: ``manipdyn.model``, ``manipdyn._support``.
"""

from .engine import CompiledEngine, compiled_engine
from .source import codegen, generate, model_sha256

__all__ = ["codegen", "generate", "model_sha256", "CompiledEngine", "compiled_engine"]
