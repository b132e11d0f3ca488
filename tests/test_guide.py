"""Issue 38 item 15: the README is short and points into the user guide (``docs/guide/``).

The README keeps what manipdyn is, the two set-up commands (the tests' one is exactly what
``.ci/run`` runs), five lines of API and a map of the guide; the guide's pages hold the rest, and
their code runs in the tests (tests/test_readme_shell.py runs the shell blocks, tests/test_newcomer3.py
the Python blocks, both through tests/guide.py).
"""

from __future__ import annotations

import re

import guide

README = guide.README.read_text(encoding="utf-8")


def test_the_readme_is_short_and_keeps_its_four_parts():
    assert README.count("\n") < 300
    for heading in ("## Set up", "## Five lines", "## The guide", "## Sources"):
        assert f"\n{heading}\n" in README, heading
    five = guide.section("## Five lines", README)
    (block,) = re.findall(r"^```python\n(.*?)^```", five, flags=re.S | re.M)
    assert block.count("\n") == 6 and "md.crosscheck" in block     # an import and five lines


def test_the_readme_test_command_is_the_one_ci_runs():
    ci = (guide.ROOT / ".ci" / "run").read_text(encoding="utf-8")
    ran = [l for l in ci.splitlines() if "pytest" in l and not l.startswith("#")][-1].strip()
    shown = [b.text for b in guide.blocks("sh") if b.page == "README.md" and "pytest" in b.text]
    assert len(shown) == 1
    # .ci/run installs quietly (-q); otherwise it is the README's command, character for character
    assert ran.replace("pip install -q ", "pip install ") in shown[0], (ran, shown[0])
    assert "pip install -e . " in README                           # the main job's install


def test_every_guide_page_is_in_the_toctree_and_on_the_readmes_map():
    names = guide.toc()
    on_disk = sorted(p.stem for p in guide.GUIDE.glob("*.md") if p.stem != "index")
    assert sorted(names) == on_disk
    for must in ("start", "arms", "dynamics", "identification", "trust", "codegen", "mujoco", "simulator",
                 "control", "montecarlo", "collisions"):
        assert must in names, must
    linked = set(re.findall(r"\]\(docs/guide/(\w+)\.md\)", guide.section("## The guide", README))) - {"index"}
    assert linked == set(names), sorted(set(names) ^ linked)
    for page in names:
        assert guide.page(page).startswith("# "), f"{page}.md starts with its title"


def test_guide_links_between_pages_name_pages_that_exist():
    for page in guide.toc():
        for target in re.findall(r"\]\((\w+)\.md(?:#[\w-]+)?\)", guide.page(page)):
            assert (guide.GUIDE / f"{target}.md").is_file(), (page, target)


def test_a_refused_negative_urdf_friction_points_at_the_guides_recipe(tmp_path):
    """Issue 46 item 8: a URDF whose <dynamics friction> is negative (FloBaRoID's LWR4+) is refused; the
    one-line error says how the rigid part loads and names the page whose recipe adds the tags' torques."""
    import manipdyn as md

    text = md.to_urdf(md.load("ur5")).replace("</joint>", '<dynamics damping="0.1" friction="-0.3"/></joint>', 1)
    (tmp_path / "neg.urdf").write_text(text)
    try:
        md.load(str(tmp_path / "neg.urdf"))
    except md.ModelError as e:
        message = str(e)
    else:
        raise AssertionError("a negative Coulomb coefficient was loaded")
    assert "friction=-0.3" in message and "without the <dynamics> tags the rigid part loads" in message
    page = re.search(r"docs/guide/(\w+)\.md", message).group(1)
    assert "<dynamics>" in guide.page(page) and "coulomb * np.sign(log.qd)" in guide.page(page)
