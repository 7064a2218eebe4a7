"""The workbook as a static website: ``python -m tissuefem book`` (and the last step of ``build``).

Each chapter becomes one HTML page (nbconvert's HTML exporter, from its executed copy in ``build/chapters/``,
outputs embedded, formulas typeset by a copy of MathJax in the site: no network needed) linked to its
neighbours, the contents and the errata. The index page is the syllabus: each chapter's goals (from its first
cell) and time (stated there, :func:`stated_minutes`, or estimated, :func:`estimate_minutes`); a chapter in
sittings (``chNNa_*``, ``chNNb_*``) shows as "6a", "6b". With chapter 9 comes an appendix page: the tables of
its recorded study, knob by knob (:func:`appendix_cells`), which the chapter links to instead of printing.
Every link is relative: copy the folder to any web server, or open ``index.html`` from disk.
"""

from __future__ import annotations

import contextlib
import html
import os
import re
import shutil
import importlib.util
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING
from urllib.parse import unquote, urlsplit

from .bench.accuracy_cost import RESIDUAL_COLUMN_NOTE, format_knob_table, recorded_results
from .notebooks import chapter_label, chapter_paths, missing_figures

if TYPE_CHECKING:  # nbconvert, nbformat and their templates load where a page is written: the command line starts fast
    import nbformat
    from nbconvert import HTMLExporter

#: reading speed for the chapters' prose: technical text with equations, about half that of plain prose
WORDS_PER_MINUTE = 100
#: reading, running and looking at the result of code, per line
MINUTES_PER_CODE_LINE = 0.2
#: one exercise of chapters/exercises, derived and written and graded
MINUTES_PER_EXERCISE = 20

ERRATA_HEADING = "Errata to the lecture notes"

#: the book's appendix: every setting of chapter 9's recorded study in tables, knob by knob (the chapter keeps
#: the Pareto reading, the verification and the recommendations; it links here)
APPENDIX_PAGE = "appendix_ch09_knobs.html"
APPENDIX_TITLE = "Appendix: chapter 9, knob by knob"
APPENDIX_CHAPTER = "ch09_accuracy_cost"

#: where the site keeps its copy of MathJax (2.7, from the ``jupyter-server-mathjax`` package), and the
#: configuration it loads: TeX and AMS macros, HTML-CSS output with its web fonts, in safe mode
MATHJAX_DIR = "mathjax"
MATHJAX_CONFIG = "TeX-AMS-MML_HTMLorMML-full,Safe"

_TEMPLATE = r"""
{%- extends 'lab/index.html.j2' -%}
{%- block html_head_js_requirejs -%}{%- endblock html_head_js_requirejs -%}
{%- block jupyter_widgets -%}{%- endblock jupyter_widgets -%}
{%- block html_head_js_mermaidjs -%}{%- endblock html_head_js_mermaidjs -%}
{%- block html_head_js_mathjax -%}
<script type="text/x-mathjax-config">
MathJax.Hub.Config({
  tex2jax: {inlineMath: [['$', '$'], ['\\(', '\\)']], displayMath: [['$$', '$$'], ['\\[', '\\]']],
            processEscapes: true, processEnvironments: true},
  TeX: {equationNumbers: {autoNumber: "AMS", useLabelIds: true}},
  messageStyle: "none", CommonHTML: {linebreaks: {automatic: true}},
  // the copy in the site ships the STIX-Web fonts only: without this, MathJax looks for its TeX fonts
  // and fails on some symbols (a prime, h'(J))
  "HTML-CSS": {availableFonts: ["STIX-Web"], preferredFont: "STIX-Web", webFont: "STIX-Web", imageFont: null,
               linebreaks: {automatic: true}}
});
</script>
<script async src="{{ resources.book_mathjax_url }}"></script>
{%- endblock html_head_js_mathjax -%}
{% block extra_css %}
<style type="text/css">
nav.book { font-family: var(--jp-ui-font-family, sans-serif); font-size: 14px; display: flex;
           gap: 1em; justify-content: space-between; flex-wrap: wrap; padding: 8px 16px;
           background: #f3f5f7; border-bottom: 1px solid #d0d7de; }
nav.book.bottom { border-top: 1px solid #d0d7de; border-bottom: none; margin-top: 2em; }
nav.book a { text-decoration: none; }
nav.book .middle { flex: 1; text-align: center; }
div.book-note { margin: 1em 16px; padding: 8px 12px; background: #fff8c5; border: 1px solid #d4a72c; }
</style>
{% endblock extra_css %}
{%- block body_header -%}
{{ super() }}
{{ resources.book_nav_top }}
{{ resources.book_note }}
{%- endblock body_header -%}
{% block body_footer %}
{{ resources.book_nav_bottom }}
{{ super() }}
{% endblock body_footer %}
"""


@dataclass
class Chapter:
    """One chapter of the site: its source, the notebook shown, and what the syllabus says."""

    source: Path
    notebook: nbformat.NotebookNode
    executed: bool
    title: str
    goals: str
    minutes: int
    exercises: int
    label: str

    @property
    def page(self) -> str:
        return f"chapters/{self.source.stem}.html"


# --- reading the chapters -------------------------------------------------------------------------

def _first_cell_text(nb) -> str:
    return next((cell.source for cell in nb.cells if cell.cell_type == "markdown"), "")


def chapter_title(nb, fallback: str) -> str:
    """The first heading of the first Markdown cell (``# Chapter 1 — ...``)."""
    return next((line.lstrip("#").strip() for line in _first_cell_text(nb).splitlines() if line.startswith("#")),
                fallback)


def chapter_goals(nb) -> str:
    """The ``**Goals.** ...`` paragraph of a chapter's first cell without its label, else the first paragraph
    after the title (Markdown)."""
    paragraphs = [p for p in map(str.strip, re.split(r"\n\s*\n", _first_cell_text(nb))) if p and not p.startswith("#")]
    for p in paragraphs:
        if re.match(r"\**\s*Goals?\b", p):
            return re.sub(r"^\**\s*Goals?\.?\s*\**\.?\s*", "", p).strip()
    return paragraphs[0] if paragraphs else ""


def _execution_seconds(nb) -> float:
    """Seconds the executed cells took (nbclient's timing metadata), 0 when unknown."""
    total = 0.0
    for cell in nb.cells:
        timing = cell.get("metadata", {}).get("execution", {})
        with contextlib.suppress(KeyError, TypeError, ValueError):  # a cell not run, or its times not recorded
            total += (datetime.fromisoformat(timing["shell.execute_reply"])
                      - datetime.fromisoformat(timing["iopub.execute_input"])).total_seconds()
    return total


_FENCED = re.compile(r"^```.*?^```[ \t]*$", re.S | re.M)


def _lines(text: str) -> int:
    return len([ln for ln in text.splitlines() if ln.strip()])


def _section(heading: str) -> re.Pattern:
    """A Markdown section: the line ``## heading`` (a regular expression) and its body, group 1, up to the next
    ``## ``."""
    return re.compile(rf"^## {heading}\n?(.*?)(?=^## |\Z)", re.S | re.M)


_TRY = _section(r"What to try\b.*?$")


def reading_load(nb) -> tuple[int, int]:
    """``(words, code_lines)`` of a chapter: fenced code in Markdown counts as code, and the "What to try" section
    is left out (like the exercises, it is for after the sitting)."""
    words = code_lines = 0
    for c in nb.cells:
        if c.cell_type == "markdown":
            text = _TRY.sub("", c.source)
            fenced = _FENCED.findall(text)
            words += len(_FENCED.sub("", text).split())
            code_lines += sum(max(_lines(block) - 2, 0) for block in fenced)
        elif c.cell_type == "code":
            code_lines += _lines(c.source)
    return words, code_lines


def estimate_minutes(nb) -> int:
    """Time to work through a chapter, exercises apart: prose at :data:`WORDS_PER_MINUTE`, code at
    :data:`MINUTES_PER_CODE_LINE` and the cells' run time, rounded up to 5 minutes."""
    words, code_lines = reading_load(nb)
    minutes = words / WORDS_PER_MINUTE + code_lines * MINUTES_PER_CODE_LINE + _execution_seconds(nb) / 60
    return max(5, 5 * -(-int(round(minutes)) // 5))


def stated_minutes(nb) -> int | None:
    """The time a chapter states in its first cell (``*Time: about 40 min ...*``), or None."""
    m = re.search(r"Time:?\**\s*about\s+(\d+)\s*min", _first_cell_text(nb))
    return int(m.group(1)) if m else None


def chapter_exercises(nb) -> list[str] | None:
    """The exercises a chapter's "Exercises" section lists (``**6.1**``, ...), or ``None`` without one (the
    syllabus then counts the stubs of its exercise file)."""
    text = "\n\n".join(c.source for c in nb.cells if c.cell_type == "markdown")
    m = _section(r"Exercises.*?$").search(text)
    return re.findall(r"\*\*(\d+\.\d+)\*\*", m.group(0)) if m else None


def count_exercises(exercise_file: Path) -> int:
    """The stub functions of a chapter's exercise file (``def name(...)`` at top level, not private)."""
    return len(re.findall(r"^def (?!_)\w+\(", exercise_file.read_text(), flags=re.M)) if exercise_file.exists() else 0


def readme_section(readme_text: str, heading: str) -> str:
    """The body of the ``## heading`` section of a Markdown file, up to the next ``## ``."""
    m = _section(rf"[ \t]*{re.escape(heading)}[ \t]*$").search(readme_text)
    if m is None:
        raise ValueError(f"the README has no section '## {heading}'")
    return m.group(1).strip()


def readme_intro(readme_text: str) -> str:
    """The README's opening: everything between its title and its first ``## `` section."""
    lines = re.split(r"^## ", readme_text, maxsplit=1, flags=re.M)[0].splitlines()
    return "\n".join(line for line in lines if not line.startswith("# ")).strip()


# --- writing pages ------------------------------------------------------------------------------

def _exporter() -> HTMLExporter:
    from jinja2 import DictLoader
    from nbconvert import HTMLExporter

    exporter = HTMLExporter(template_name="lab", extra_loaders=[DictLoader({"book.html.j2": _TEMPLATE})],
                            template_file="book.html.j2")
    exporter.exclude_input_prompt = True
    exporter.exclude_output_prompt = True
    return exporter


def _href(page: str, target: str) -> str:
    """The relative link from the site's ``page`` to its file ``target`` (both paths from the site's root)."""
    return os.path.relpath(target, os.path.dirname(page) or ".").replace(os.sep, "/")


def _link(page: str, target: str, text: str) -> str:
    return f'<a href="{html.escape(_href(page, target))}">{text}</a>'


def _nav(page: str, chapters: list[Chapter], where: str) -> str:
    index = next((i for i, c in enumerate(chapters) if c.page == page), None)
    left = right = "<span></span>"
    if index is not None and index > 0:
        left = _link(page, chapters[index - 1].page, f"← {html.escape(chapters[index - 1].title)}")
    if index is not None and index + 1 < len(chapters):
        right = _link(page, chapters[index + 1].page, f"{html.escape(chapters[index + 1].title)} →")
    middle = f'{_link(page, "index.html", "Contents")} · {_link(page, "errata.html", "Errata")}'
    return f'<nav class="book {where}">{left}<span class="middle">{middle}</span>{right}</nav>'


#: an ``href`` or ``src`` attribute: its ``prefix``, its quote and its value
_ATTR = re.compile(r'(\s(?:href|src)=)(["\'])(.*?)\2', re.S)


class _Links:
    """Rewrites the relative links of a page for the site and copies the files they name."""

    def __init__(self, root: Path, outdir: Path, chapter_pages: dict[str, str], readme: Path):
        self.root, self.outdir, self.chapter_pages, self.readme = root, outdir, chapter_pages, readme
        appendix = {APPENDIX_PAGE} if f"{APPENDIX_CHAPTER}.ipynb" in chapter_pages else set()
        self.site_pages = {"index.html", "errata.html", *appendix, *chapter_pages.values()}
        self.warnings: list[str] = []

    def __call__(self, page_html: str, page: str, source_dir: Path) -> str:
        def fix(match):
            prefix, quote, value = match.groups()
            new = self._target(value, page, source_dir)  # None: the attribute is dropped, the link text stays
            return "" if new is None else f"{prefix}{quote}{new}{quote}"

        return _ATTR.sub(fix, page_html)

    def _target(self, value: str, page: str, source_dir: Path):
        parts = urlsplit(html.unescape(value))
        if parts.scheme or parts.netloc or value.startswith(("#", "/")) or not parts.path:
            return value  # absolute, data:, mailto:, in-page anchors
        fragment = f"#{parts.fragment}" if parts.fragment else ""
        in_site = os.path.normpath(os.path.join(os.path.dirname(page), unquote(parts.path))).replace(os.sep, "/")
        if in_site in self.site_pages or in_site.startswith(f"{MATHJAX_DIR}/"):
            return value  # already a page of the site (the syllabus, the navigation) or its copy of MathJax
        target = (source_dir / unquote(parts.path)).resolve()
        if target.suffix == ".ipynb" and target.name in self.chapter_pages:
            site_path = self.chapter_pages[target.name]
        elif target == self.readme.resolve() and "errata" in parts.fragment.lower():
            site_path, fragment = "errata.html", ""  # the README's errata have a page, the rest is the index page's
        elif target == self.readme.resolve():
            site_path = "index.html"
        elif target.is_relative_to(self.root.resolve()) and target.is_file():
            site_path = target.relative_to(self.root.resolve()).as_posix()
            (self.outdir / site_path).parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(target, self.outdir / site_path)
        else:
            self.warnings.append(f"{page}: link to {value} leads to no file of the workbook; link removed")
            return None
        return html.escape(_href(page, site_path) + fragment)


def _markdown_notebook(title: str, cells: list[str]) -> nbformat.NotebookNode:
    import nbformat

    nb = nbformat.v4.new_notebook()
    nb.metadata["title"] = title
    nb.cells = [nbformat.v4.new_markdown_cell(text) for text in [f"# {title}", *cells]]
    return nb


def _copy_mathjax(outdir: Path) -> None:
    """Copy the MathJax that installs with the project (``jupyter-server-mathjax``) into the site, without the
    translations other than English (the pages never load them)."""
    spec = importlib.util.find_spec("jupyter_server_mathjax")  # where it is, without starting its server extension
    if spec is None or not spec.submodule_search_locations:
        raise RuntimeError("jupyter-server-mathjax is not installed: pip install jupyter-server-mathjax")
    source = Path(list(spec.submodule_search_locations)[0]) / "static"
    if not (source / "MathJax.js").is_file():
        raise RuntimeError(f"jupyter-server-mathjax has no MathJax.js in {source}: reinstall it")
    shutil.copytree(source, outdir / MATHJAX_DIR, ignore=lambda folder, names: [
        n for n in names if Path(folder) == source / "localization" and n != "en"])


def syllabus_cells(chapters: list[Chapter], intro: str) -> list[str]:
    """The index page's Markdown cells: the README's opening, a table of times, each chapter's goals."""
    rows = ["| | chapter | reading and running | exercises | in all |", "|---:|---|---:|---:|---:|"]
    total = 0
    for c in chapters:
        practice = c.exercises * MINUTES_PER_EXERCISE
        total += c.minutes + practice
        ex = f"{c.exercises} × {MINUTES_PER_EXERCISE} min" if c.exercises else "—"
        rows.append(f"| {c.label} | [{c.title}]({c.page}) | {c.minutes} min | {ex} | {c.minutes + practice} min |")
    parts = [
        intro,
        "## Syllabus",
        "Estimated times, each a sitting of at most an hour: the prose at about "
        f"{WORDS_PER_MINUTE} words a minute, the code at {MINUTES_PER_CODE_LINE * 60:.0f} seconds a line "
        f"plus the time its cells take to run (the time each chapter states at its top), and "
        f"{MINUTES_PER_EXERCISE} minutes for each exercise (about {total / 60:.0f} hours in all). "
        "The [errata](errata.html) list the slips found in the lecture notes.",
        "\n".join(rows),
    ]
    for c in chapters:
        # drop the goals' own lead-in "By the end of this chapter you can" (said once here)
        goals = re.sub(r"^By the end of this chapter you can\s*\n", "", c.goals).strip()
        status = "" if c.executed else "\n\n*(This chapter's outputs are missing from the site: it was not executed.)*"
        parts.append(f"### {c.label}. [{c.title}]({c.page})\n\n*About {c.minutes} min"
                     + (f", and {c.exercises} exercise{'s' if c.exercises != 1 else ''}*" if c.exercises else "*")
                     + f"\n\nBy the end of this chapter you can\n\n{goals}{status}")
    if any(c.source.stem == APPENDIX_CHAPTER for c in chapters):
        parts.append(f"## Appendix\n\n[{APPENDIX_TITLE}]({APPENDIX_PAGE}): every setting of chapter 9's recorded "
                     "study, one table per benchmark and knob, for reference after the chapter.")
    return parts


def appendix_cells() -> list[str]:
    """The appendix page's Markdown cells below its title: every setting of the study chapter 9 reads (the
    recorded run the package ships, :func:`~tissuefem.workbook.bench.accuracy_cost.recorded_results`), one table
    per benchmark and knob, the baseline marked."""
    results = recorded_results()
    machine = results["machine"]
    chapter = f"chapters/{APPENDIX_CHAPTER}.html"
    cells = [f"The tables behind [chapter 9]({chapter})'s Pareto plots: the recorded study (plan "
             f"'{results['plan_name']}', {len(results['knobs'])} settings, {results['seconds'] / 60:.0f} minutes "
             f"on {machine['cpu_count']} cores; python {machine['python']}, numpy {machine['numpy']}, scipy "
             f"{machine['scipy']}, scikit-fem {machine['scikit-fem']}). Each row is the baseline with one knob "
             "changed: *ms/frame* is the median wall time of a frame in that one run, *Newton/frame* the mean "
             "number of Newton iterations, *rel. L2 error* the largest relative $L^2$ distance to the reference "
             "over the run's checkpoints (chapter 9, sections 1 and 2), *converged* the share of frames that met "
             "the Newton tolerance. The errors are reproducible; the timings are one machine's, some taken while "
             "other work ran on it: compare them within a table, and read the chapter for what they mean.",
             RESIDUAL_COLUMN_NOTE]
    for benchmark in dict.fromkeys(r["benchmark"] for r in results["knobs"]):
        rows = [r for r in results["knobs"] if r["benchmark"] == benchmark]
        tables = [f"## The {benchmark}"]
        for knob in dict.fromkeys(r["knob"] for r in rows):
            marked = [dict(r, value=f"{r['value']} (baseline)") if r["baseline"] else r
                      for r in rows if r["knob"] == knob]
            tables.append(f"### {benchmark}: {knob}\n\n{format_knob_table(marked)}")
        cells.append("\n\n".join(tables))
    return cells


# --- the site -----------------------------------------------------------------------------------

def build_book(chapters_dir, executed_dir, outdir, progress=print) -> list[Path]:
    """Write the static site into ``outdir``; returns the pages written. A chapter without an executed copy in
    ``executed_dir`` is shown without outputs, with a note; the README beside ``chapters_dir`` gives the index
    page's opening and the errata, ``chapters_dir/exercises`` the exercise counts. Relative links go to a
    chapter's page, the errata page or a copy of the linked workbook file."""
    chapters_dir, executed_dir, outdir = Path(chapters_dir), Path(executed_dir), Path(outdir)
    root = chapters_dir.resolve().parent
    readme, exercises_dir = root / "README.md", chapters_dir / "exercises"
    readme_text = readme.read_text(encoding="utf-8")
    sources = chapter_paths(chapters_dir)
    if not sources:
        raise ValueError(f"no chapter notebooks chNN_*.ipynb in {chapters_dir}")

    import nbformat

    chapters = []
    for source in sources:
        executed = executed_dir / source.name
        nb = nbformat.read(executed if executed.exists() else source, as_version=4)
        listed = chapter_exercises(nb)
        chapters.append(Chapter(source=source, notebook=nb, executed=executed.exists(),
                                title=chapter_title(nb, source.stem), goals=chapter_goals(nb),
                                minutes=stated_minutes(nb) or estimate_minutes(nb),
                                # a chapter split into parts shares one exercise file: count what each part lists
                                exercises=len(listed) if listed is not None else
                                count_exercises(exercises_dir / f"{source.stem[:4]}.py"),
                                label=chapter_label(source)))

    if outdir.exists():
        shutil.rmtree(outdir)
    (outdir / "chapters").mkdir(parents=True)
    _copy_mathjax(outdir)
    exporter = _exporter()
    links = _Links(root, outdir, {c.source.name: c.page for c in chapters}, readme)
    written = []

    def write(page, nb, source_dir=root, note=""):
        """Write a page of the site: the notebook ``nb`` with the navigation, its links made the site's."""
        resources = {"metadata": {"name": Path(page).stem, "path": str(source_dir)}, "book_note": note,
                     "book_mathjax_url": f"{_href(page, f'{MATHJAX_DIR}/MathJax.js')}?config={MATHJAX_CONFIG}",
                     "book_nav_top": _nav(page, chapters, "top"), "book_nav_bottom": _nav(page, chapters, "bottom")}
        written.append(outdir / page)
        written[-1].write_text(links(exporter.from_notebook_node(nb, resources=resources)[0], page, source_dir),
                               encoding="utf-8")
        progress(f"[book] {written[-1]}")

    for c in chapters:
        for line in missing_figures(c.notebook) if c.executed else []:
            links.warnings.append(f"{c.page}: {line}: the page shows no picture where the text describes one")
        write(c.page, c.notebook, chapters_dir.resolve(), "" if c.executed else (
            '<div class="book-note">This chapter has not been executed, so its outputs are missing: '
            "run <code>python -m tissuefem build</code>.</div>"))
    write("index.html", _markdown_notebook("tissuefem: the workbook",
                                           syllabus_cells(chapters, readme_intro(readme_text))))
    write("errata.html", _markdown_notebook(ERRATA_HEADING, [readme_section(readme_text, ERRATA_HEADING)]))
    if APPENDIX_PAGE in links.site_pages:
        write(APPENDIX_PAGE, _markdown_notebook(APPENDIX_TITLE, appendix_cells()))
    for warning in links.warnings:
        progress(f"[book] warning: {warning}")
    return written
