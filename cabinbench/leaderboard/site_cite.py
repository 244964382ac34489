"""The site's "cite this" block: ``CITATION.cff`` as BibTeX and as itself."""

from __future__ import annotations

from pathlib import Path

import yaml

from cabinbench.errors import UsageError
from cabinbench.leaderboard.site_html import escape
from cabinbench.records import safe_name


def bibtex(citation: dict) -> str:
    """BibTeX entries for CITATION.cff: the software, then each reference (the dissertation)."""

    def authors(people: list[dict]) -> str:
        names = [
            person.get("name") or f"{person.get('family-names', '')}, {person.get('given-names', '')}"
            for person in people
        ]
        return " and ".join(
            f"{{{name}}}" if "name" in person else name for name, person in zip(names, people)
        )

    entries = [
        "@software{cabinbench,\n"
        f"  title = {{{citation['title']}}},\n"
        f"  author = {{{authors(citation.get('authors', []))}}},\n"
        f"  version = {{{citation.get('version', '')}}},\n"
        f"  license = {{{citation.get('license', '')}}},\n"
        f"  note = {{{citation.get('message', '')}}}\n"
        "}"
    ]
    for index, reference in enumerate(citation.get("references", [])):
        kind = "phdthesis" if reference.get("type") == "thesis" else "misc"
        family = reference["authors"][0].get("family-names", "ref")
        key = f"{safe_name(family).lower()}{reference.get('year', '')}"
        fields = [
            ("title", reference.get("title")),
            ("author", authors(reference.get("authors", []))),
            ("school", reference.get("institution", {}).get("name")),
            ("year", reference.get("year")),
            ("type", reference.get("thesis-type")),
        ]
        body = ",\n".join(f"  {name} = {{{value}}}" for name, value in fields if value)
        entries.append(f"@{kind}{{{key if index == 0 else f'{key}_{index}'},\n{body}\n}}")
    return "\n\n".join(entries) + "\n"


def cite_block(citation_path: Path) -> tuple[str, str]:
    """(the HTML block, the BibTeX text) for ``CITATION.cff``."""
    if not citation_path.is_file():
        raise UsageError(f"--site: no {citation_path} here; run from the repository root")
    text = citation_path.read_text(encoding="utf-8")
    bib = bibtex(yaml.safe_load(text))
    block = (
        '<h2 id="cite">Cite this</h2><p>If you use cabinbench or its leaderboard, cite it '
        '(<a href="cabinbench.bib">cabinbench.bib</a>, <a href="CITATION.cff">CITATION.cff</a>):</p>'
        f"<pre>{escape(bib)}</pre><details><summary>CITATION.cff</summary><pre>{escape(text)}</pre></details>"
    )
    return block, bib
