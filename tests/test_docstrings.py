"""Docstrings say what the code does: none in src/caustica cites an issue number (those go to docs/)."""
import ast
import re
from pathlib import Path

SOURCE = Path(__file__).resolve().parents[1] / "src" / "caustica"

# "issue 12", "Issue 22 part 2", "issues 23 and 19", "issues 12, 13", "#37"
ISSUE_REFERENCE = re.compile(r"\bissues?\s+\d+(?:\s*(?:,|and|&)\s*\d+)*|(?<![\w#&])#\d+\b", re.IGNORECASE)


def issue_references(text: str) -> list[str]:
    """The issue references in ``text``."""
    return [m.group(0) for m in ISSUE_REFERENCE.finditer(text)]


def docstrings(path: Path):
    """(line, docstring) of the module, classes and functions of ``path``."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            text = ast.get_docstring(node, clean=False)
            if text:
                yield getattr(node, "lineno", 1), text


def test_the_matcher_finds_issue_references_and_nothing_else():
    assert issue_references("the soak's step (issue 17)") == ["issue 17"]
    assert issue_references("Issues 23 and 19, then issue 4") == ["Issues 23 and 19", "issue 4"]
    assert issue_references("fixed in #37.") == ["#37"]
    assert issue_references("an issue with 3 lights; 16 spp; texel #ff00ff is &#38; colour") == []
    assert issue_references("renders the issue-free case, the # of photons, frame 12") == []


def test_no_docstring_cites_an_issue_number():
    found = [f"{path.relative_to(SOURCE.parent)}:{line}: {ref}"
             for path in sorted(SOURCE.rglob("*.py"))
             for line, text in docstrings(path)
             for ref in issue_references(text)]
    assert not found, "docstrings citing issues (move them to docs/):\n" + "\n".join(found)
