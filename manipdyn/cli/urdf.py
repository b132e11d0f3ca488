"""``manipdyn urdf``: write the URDF of arms (and the loop ``manipdyn mjcf`` shares).

Layer 7 (CLI, the top).
"""

from __future__ import annotations

import os
import warnings

from .._support.errors import ModelError, PhysicalConsistencyWarning
from .._support.files import atomic_write_text, link_out_of
from ..formats.save import to_urdf
from ..formats.loading import models
from ..formats.urdf.writer import urdf_losses
from .argblocks import add_writer_command
from .common import EXIT_OK, creatable_folder, is_urdf, load_all, output_folder, urdf_target, usage_error

__all__ = ["register", "run", "write_models"]


def write_models(args, command: str, ext: str, write, losses) -> int:
    """Load ``args.models`` (or ``--all``), write ``OUTDIR/<name>.<ext>`` with ``write(arm, path)``
    for each, and print what the format does not hold (``losses(arm)``, one line each).

    Every input is read, every text built and every target checked before OUTDIR is created (a
    refused model leaves no folder behind); a target that is a symbolic link leading outside
    OUTDIR is refused, naming it."""
    specs = list(args.models)
    if args.all:
        specs = models() + specs
    if not specs:
        if args.outdir in models() or is_urdf(args.outdir) or args.outdir.lower().endswith(".toml") \
                or args.outdir.startswith("erd:"):
            return usage_error(command, f"missing OUTDIR: {args.outdir!r} is a model, not the folder to "
                                        f"write into; usage: manipdyn {command} MODEL_OR_FILE ... OUTDIR")
        return usage_error(command, "name at least one model or pass --all")
    if os.path.exists(args.outdir) and not os.path.isdir(args.outdir):
        raise ModelError(f"OUTDIR {args.outdir}: cannot create the folder: a file of that name exists")
    loaded = load_all(dict.fromkeys(specs), args.tip)   # each spec once, all loaded before writing
    seen: dict = {}
    exists = os.path.isdir(args.outdir)
    if not exists:              # created only once everything is read
        creatable_folder(args.outdir, "OUTDIR")
    paths = [urdf_target(args.outdir, arm, seen, "OUTDIR", specs, ext, check=exists) for _spec, arm, _notes in loaded]
    for path in paths:
        far = link_out_of(args.outdir, path)
        if far is not None:
            raise ModelError(f"OUTDIR {args.outdir}: {os.path.basename(path)} is a symbolic link to {far}, outside "
                             f"OUTDIR; writing through it would replace that file: remove the link, or choose "
                             f"another OUTDIR (nothing was written)")
    texts = []
    for _spec, arm, _notes in loaded:      # every text (and its account) built before the folder exists
        with warnings.catch_warnings():      # the losses printed below say it, once
            warnings.simplefilter("ignore", PhysicalConsistencyWarning)
            texts.append((write(arm), losses(arm)))
    output_folder(args.outdir, "OUTDIR")
    try:
        for path, (text, lost) in zip(paths, texts):
            try:
                atomic_write_text(path, text)
            except OSError as exc:
                raise ModelError(f"OUTDIR {args.outdir}: cannot write {os.path.basename(path)} "
                                 f"({exc.strerror})") from None
            print(f"wrote {path}")
            for line in lost:
                print(f"  not held: {line}")
    finally:
        if not exists:
            try:
                os.rmdir(args.outdir)            # only when nothing was written into it
            except OSError:
                pass
    return EXIT_OK


def run(args) -> int:
    raw = bool(args.as_published)
    return write_models(args, "urdf", "urdf", lambda arm: to_urdf(arm, as_published=raw),
                        lambda arm: urdf_losses(arm, as_published=raw))


def register(sub) -> None:
    """Add ``manipdyn urdf``."""
    add_writer_command(sub, "urdf", "write the URDF of arms",
                       "Write <name>.urdf for each arm into OUTDIR (created if needed). "
                       "The URDF carries the arm's joint limits and says in a comment which "
                       "values are manipdyn's defaults and what URDF cannot hold of the model "
                       "(printed too, one 'not held:' line each). A body MuJoCo refuses is written "
                       "completed, with the model's base parameters (--as-published: as given). "
                       "Exit 0 written, 2 usage or model error.", "urdf", run, "MuJoCo's URDF reader refuses")
