"""README.md's "Contents" list: every link in it (and every other `](#anchor)` link of
the README) names a heading, with GitHub's anchors (lower case, punctuation other than
`-` and `_` dropped, spaces as `-`, `-1`, `-2` ... after repeats), and every `##`
section is listed."""

import re
from collections import Counter

from support import ROOT


def headings(text: str) -> list[tuple[int, str, str]]:
    """(level, title, GitHub anchor) of the README's headings outside code fences."""
    out, seen, fence = [], Counter(), False
    for line in text.splitlines():
        if line.startswith("```"):
            fence = not fence
            continue
        m = None if fence else re.match(r"^(#{1,6}) (.+)$", line)
        if m:
            base = re.sub(r"[^\w\- ]", "", m.group(2).strip().lower()).replace(" ", "-")
            n = seen[base]
            seen[base] += 1
            out.append((len(m.group(1)), m.group(2).strip(), base if n == 0 else f"{base}-{n}"))
    return out


def test_anchor_rule_matches_github_on_known_titles():
    text = "## Output (in `--out`)\n### summary.json\n## Hard cases (configs/hard/)\n## A\n## A\n"
    assert [a for _, _, a in headings(text)] == [
        "output-in---out", "summaryjson", "hard-cases-configshard", "a", "a-1"]


def test_every_anchor_link_resolves_and_every_section_is_listed():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    heads = headings(text)
    anchors = {a for _, _, a in heads}
    links = re.findall(r"\]\(#([^)\s]+)\)", text)
    assert links, "the README has no Contents links"
    assert sorted(set(links) - anchors) == []
    contents = text.split("## Contents", 1)[1].split("\n## ", 1)[0]
    listed = set(re.findall(r"\]\(#([^)\s]+)\)", contents))
    sections = [a for level, title, a in heads if level == 2 and title != "Contents"]
    assert [a for a in sections if a not in listed] == []
