"""The workbook's website: built from two tiny executed chapters and the real README's errata,
every page exists and every relative link and image resolves (the site is copyable anywhere)."""

import html
import re
import shutil
from pathlib import Path
from urllib.parse import unquote, urlsplit

import nbformat
import pytest

from tissuefem.workbook import cli
from tissuefem.workbook.book import build_book, chapter_goals, estimate_minutes, readme_section
from tissuefem.workbook.notebooks import execute_notebook

ROOT = Path(__file__).resolve().parents[2]

ALPHA_INTRO = """# Chapter 1 — Alpha: adding numbers

**Goals.** By the end of this chapter you can
1. add two numbers $a + b$ and check the sum;
2. plot a line.

*Reading:* none."""

ALPHA_BODY = """## A figure and some links

![a tiny figure](../figures/tiny.png)

The next chapter's [section](ch02_beta.ipynb#A-section), the [errata](../README.md#errata-to-the-lecture-notes),
the [README](../README.md), a file of the workbook ([scene](../scenes/pulled.toml)) and the
[scikit-fem documentation](https://scikit-fem.readthedocs.io/)."""


def _notebook(cells):
    nb = nbformat.v4.new_notebook()
    nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3", "language": "python"}
    nb.cells = [nbformat.v4.new_markdown_cell(c[3:]) if c.startswith("md:") else nbformat.v4.new_code_cell(c)
                for c in cells]
    return nb


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    root = tmp_path_factory.mktemp("workbook")
    (root / "chapters" / "exercises").mkdir(parents=True)
    (root / "figures").mkdir()
    (root / "scenes").mkdir()
    shutil.copyfile(ROOT / "README.md", root / "README.md")
    shutil.copyfile(ROOT / "figures" / "fig05_admissible_maps.png", root / "figures" / "tiny.png")
    (root / "scenes" / "pulled.toml").write_text('name = "pulled"\n')
    (root / "chapters" / "exercises" / "ch01.py").write_text(
        "def add(a, b):\n    raise NotImplementedError\n\n\ndef _helper():\n    pass\n\n\n"
        "def plot_line():\n    raise NotImplementedError\n")
    alpha = _notebook(["md:" + ALPHA_INTRO, "print(1 + 2)",
                       "import matplotlib\nmatplotlib.use('Agg')\nimport matplotlib.pyplot as plt\n"
                       "%matplotlib inline\nplt.plot([0, 1], [0, 1]);",
                       "md:" + ALPHA_BODY])
    beta = _notebook(["md:# Chapter 2 — Beta\n\n**Goals.**\n1. Multiply: $a \\times b$.",
                      "md:## A section\n\nBack to [chapter 1](ch01_alpha.ipynb).", "6 * 7"])
    for name, nb in (("ch01_alpha.ipynb", alpha), ("ch02_beta.ipynb", beta)):
        nbformat.write(nb, root / "chapters" / name)
        execute_notebook(root / "chapters" / name, root / "build" / "chapters" / name, timeout=120)
    messages = []
    pages = build_book(root / "chapters", root / "build" / "chapters", root / "build" / "book",
                       progress=messages.append)
    return root, root / "build" / "book", pages, messages


def _relative_targets(page_html):
    for double, single in re.findall(r'\s(?:href|src)=(?:"([^"]*)"|\'([^\']*)\')', page_html):
        value = html.unescape(double or single)
        parts = urlsplit(value)
        if parts.scheme or parts.netloc:
            continue
        yield value, parts


def test_every_page_exists(site):
    _, book, pages, _ = site
    expected = {"index.html", "errata.html", "chapters/ch01_alpha.html", "chapters/ch02_beta.html"}
    assert {p.relative_to(book).as_posix() for p in pages} == expected
    for page in expected:
        text = (book / page).read_text()
        assert text.startswith("<!DOCTYPE html>") and "</html>" in text


def test_every_relative_link_and_image_resolves(site):
    root, book, _, messages = site
    checked = 0
    for page in book.rglob("*.html"):
        text = page.read_text()
        assert str(root) not in text, f"{page.name} names a path of the build machine"
        for value, parts in _relative_targets(text):
            target = page if not parts.path else (page.parent / unquote(parts.path)).resolve()
            assert target.is_file(), f"{page.relative_to(book)}: {value} does not resolve"
            assert book.resolve() in target.resolve().parents, f"{value} leaves the site"
            if parts.fragment:
                # a browser looks for the fragment as written, then percent-decoded
                ids = {f'id="{html.escape(f, quote=False)}"' for f in (parts.fragment, unquote(parts.fragment))}
                assert any(i in target.read_text() for i in ids), f"{page.name}: no anchor for {value}"
            checked += 1
    assert checked > 20
    assert not [m for m in messages if "warning" in m], messages


def test_chapter_pages_show_outputs_math_figures_and_navigation(site):
    _, book, _, _ = site
    alpha = (book / "chapters" / "ch01_alpha.html").read_text()
    beta = (book / "chapters" / "ch02_beta.html").read_text()
    assert "<pre>3\n</pre>" in alpha.replace("\r", "")  # the printed output
    assert 'src="data:image/png;base64,' in alpha  # the plot, embedded
    assert 'src="../figures/tiny.png"' in alpha and (book / "figures" / "tiny.png").is_file()
    assert 'href="../scenes/pulled.toml"' in alpha and (book / "scenes" / "pulled.toml").is_file()
    assert 'href="ch02_beta.html#A-section"' in alpha and 'href="ch01_alpha.html"' in beta
    assert 'href="../errata.html"' in alpha and 'href="../index.html"' in alpha
    assert "https://scikit-fem.readthedocs.io/" in alpha
    # the math stays readable TeX in the page; MathJax typesets it when it can load
    assert "$a + b$" in alpha and "mathjax" in alpha.lower()
    # the site's own copy of MathJax typesets it, offline
    assert 'src="../mathjax/MathJax.js?config=' in alpha and (book / "mathjax" / "MathJax.js").is_file()
    # previous / next
    assert "Chapter 2 — Beta →" in alpha and "← Chapter 1 — Alpha" in beta
    assert "42" in beta


def test_the_site_loads_no_script_from_the_network(site):
    """An offline student sees typeset formulas: every script of every page is a file of the site."""
    _, book, _, _ = site
    for page in book.rglob("*.html"):
        text = page.read_text()
        remote = re.findall(r"<script[^>]*\ssrc=[\"']?(?:https?:)?//[^\"'\s>]+", text, re.I)
        assert not remote, f"{page.relative_to(book)} loads scripts from the network: {remote}"
        assert "MathJax.js?config=" in text, f"{page.relative_to(book)} loads no MathJax"


def test_executing_a_chapter_logs_no_kernel_warning(tmp_path, capfd):
    """The build log carries no "Kernel is running over TCP without encryption" per chapter."""
    path = tmp_path / "ch01_quiet.ipynb"
    nbformat.write(_notebook(["print(6 * 7)"]), path)
    nb = execute_notebook(path, timeout=120)
    assert nb.cells[0].outputs[0]["text"] == "42\n"
    out, err = capfd.readouterr()
    assert "without encryption" not in out + err


def test_index_has_the_syllabus_and_the_errata_page_the_readme_errata(site):
    _, book, _, _ = site
    index = (book / "index.html").read_text()
    assert 'href="chapters/ch01_alpha.html"' in index and 'href="errata.html"' in index
    assert "add two numbers $a + b$ and check the sum" in index and "Multiply: $a \\times b$." in index
    assert "2 × 20 min" in index  # chapter 1's two exercises (the private helper is not one)
    assert "An open teaching workbook" in index  # the README's opening
    errata = (book / "errata.html").read_text()
    assert "1D linear modulus" in errata and "Poisson" in errata and "Smaller slips" in errata
    assert "References" not in errata  # the section ends where the next begins


def test_goals_time_and_sections_are_read_from_the_sources():
    nb = nbformat.read(ROOT / "chapters" / "ch01_linear_1d.ipynb", as_version=4)
    goals = chapter_goals(nb)
    assert goals.startswith("By the end of this chapter you can") and "convergence rates" in goals
    assert "Reading" not in goals
    assert 10 <= estimate_minutes(nb) <= 60 and estimate_minutes(nb) % 5 == 0
    text = (ROOT / "README.md").read_text()
    assert readme_section(text, "Errata to the lecture notes").startswith("Each slip below")
    with pytest.raises(ValueError, match="no section"):
        readme_section(text, "No such section")


def test_book_command_writes_the_site(site, tmp_path, monkeypatch, capsys):
    root, _, _, _ = site
    monkeypatch.chdir(root)
    assert cli.main(["book", "--out", str(tmp_path / "site")]) == 0
    assert (tmp_path / "site" / "chapters" / "ch02_beta.html").is_file()
    assert "index.html" in capsys.readouterr().out


def test_every_chapter_states_a_time_that_fits_a_sitting():
    """Each chapter says at its top how long it takes; the syllabus shows that time. It must cover the estimate
    from its prose and code (the run time comes on top, hence the margin) and fit a sitting of an hour."""
    from tissuefem.workbook.book import stated_minutes
    from tissuefem.workbook.notebooks import chapter_paths

    for path in chapter_paths(ROOT / "chapters"):
        nb = nbformat.read(path, as_version=4)
        stated, estimate = stated_minutes(nb), estimate_minutes(nb)
        assert stated is not None, f"{path.name} states no time (*Time: about N min ...*)"
        assert estimate <= stated <= estimate + 15, (path.name, stated, estimate)
        assert stated <= 60, f"{path.name}: {stated} min is more than a sitting; split the chapter"


def test_parts_of_a_chapter_are_named_and_counted():
    from tissuefem.workbook.book import chapter_exercises, stated_minutes
    from tissuefem.workbook.notebooks import chapter_label, chapter_paths

    names = [p.name for p in chapter_paths(ROOT / "chapters")]
    assert "ch06a_inversion.ipynb" in names and "ch06b_inversion_robust.ipynb" in names
    assert names.index("ch06a_inversion.ipynb") < names.index("ch06b_inversion_robust.ipynb") < \
        names.index("ch07_time_stepping.ipynb")
    assert chapter_label(ROOT / "chapters" / "ch06a_inversion.ipynb") == "6a"
    assert chapter_label("ch10_cutting.ipynb") == "10"
    with pytest.raises(ValueError, match="chapter file name"):
        chapter_label("notes.ipynb")
    a = nbformat.read(ROOT / "chapters" / "ch06a_inversion.ipynb", as_version=4)
    b = nbformat.read(ROOT / "chapters" / "ch06b_inversion_robust.ipynb", as_version=4)
    assert chapter_exercises(a) == ["6.1", "6.2", "6.3"] and chapter_exercises(b) == []
    nb = _notebook(["md:# Chapter 1 — x\n\n*Time: about 35 min to read and run.*"])
    assert stated_minutes(nb) == 35


def test_the_readme_lists_every_chapter_with_its_stated_time():
    from tissuefem.workbook.book import stated_minutes
    from tissuefem.workbook.notebooks import chapter_label, chapter_paths

    text = (ROOT / "README.md").read_text()
    for path in chapter_paths(ROOT / "chapters"):
        minutes = stated_minutes(nbformat.read(path, as_version=4))
        row = f"| {chapter_label(path)} | `chapters/{path.name}` | {minutes} min |"
        assert row in text, f"the README's chapter table should have the row {row}"
