"""Issue 46 (a newcomer, round six): what a written file does not hold, said in Python too.

Item 6 (md.write_urdf silent in Python; the URDF of an identified model said to drop what it
holds), item 17's did-you-mean, item 29's model file with a BOM.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import manipdyn as md
from manipdyn.cli import main


# -- 6. md.write_urdf / write_mjcf warn what the file does not hold ------------------------------
def test_item6_write_urdf_warns_what_the_urdf_drops(tmp_path):
    """Issue 46 item 6: a Pinocchio user loading the written Panda URDF found pin.rnea 0.37 N m off
    arm.inverse_dynamics, with no word in Python (the CLI prints ``not held:`` lines).  write_urdf now
    warns one FormatLossWarning listing what the comment lists; an arm it holds wholly gives none."""
    from manipdyn.formats.urdf.writer import urdf_losses

    arm = md.load("panda")
    lost = urdf_losses(arm, as_published=False)
    assert any("friction" in x for x in lost), lost        # the Panda's law is what pin.rnea misses
    with pytest.warns(md.FormatLossWarning) as caught:
        md.write_urdf(arm, tmp_path / "panda.urdf")
    text = str(caught[0].message)
    assert "panda.urdf" in text and "friction law" in text
    assert issubclass(md.FormatLossWarning, md.ModelNoteWarning)
    with pytest.warns(md.FormatLossWarning, match="MJCF"):
        md.write_mjcf(arm, tmp_path / "panda.xml")


def test_item6_a_urdf_holding_the_fitted_law_does_not_say_it_drops_it(tmp_path, capsys):
    """The URDF of a model identified with ``--friction`` (viscous and sharp Coulomb, held by the links'
    ``<dynamics>``) said "written as URDF, which holds neither the fitted friction law nor rotor
    inertia"; the law is held, so no such doubt; the words of a law it does not hold name only what
    is dropped."""
    pytest.importorskip("cvxpy", reason="identification needs the identify extra (cvxpy)")
    from test_bands import _log

    _log(tmp_path / "fit.csv", md.load("ur5"), 11)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = md.identify("ur5", [tmp_path / "fit.csv"], friction=True, band_folds=0)
    model = tmp_path / "id.toml"
    r.save(model)
    assert main(["urdf", str(model), str(tmp_path / "out")]) == 0
    printed = capsys.readouterr().out
    text = (tmp_path / "out" / "id.urdf").read_text()
    assert "<dynamics damping=" in text
    assert "holds neither the fitted friction law" not in text and "does not hold the fitted friction" not in text
    assert "dropped" not in printed


def test_item6_friction_words_name_only_what_is_dropped():
    from manipdyn.formats.losses import urdf_friction_words

    fv, fc = np.array([0.1, 0.2]), np.array([0.3, 0.4])
    law = md.Friction(viscous=fv, coulomb=fc, offset=np.array([0.01, 0.02]), smoothing=0.01)
    words = urdf_friction_words(law, fv, fc)
    assert "viscous and Coulomb friction held" in words
    dropped = words.split("dropped:")[1]
    assert "offset" in dropped and "viscous" not in dropped and "coulomb" not in dropped.lower().split(";")[0]
    assert "smoothing 0.01" in words


# -- 17. did you mean, case aside ---------------------------------------------------------------
@pytest.mark.parametrize("name, best", [("UR5", "ur5"), ("Panda", "panda"), ("PUMA560", "puma560")])
def test_item17_a_name_in_other_case_gets_did_you_mean(name, best):
    """Issue 46 item 17: ``md.load("UR5")`` gave no did-you-mean (difflib compares case)."""
    with pytest.raises(md.ModelError, match=rf"did you mean '{best}'"):
        md.load(name)
