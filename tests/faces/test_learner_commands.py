"""The learner's commands (grader/faces/learner_commands.py): `grade quiz` and `grade submit` read the learner id
in learner.yaml by one rule (grader.quiz.learner_in_file) and give one reason, with the file and line, for an id
they cannot use."""

from __future__ import annotations

import shutil

import pytest
from click.testing import CliRunner

from grader.faces.cli import main
from tests.support import REPO


def _project(tmp_path, learner_yaml: str):
    root = tmp_path / "project"
    shutil.copytree(REPO / "exercises", root / "exercises", ignore=shutil.ignore_patterns("__pycache__"))
    (root / "exercises" / "answers" / "learner.yaml").write_text(learner_yaml, encoding="utf-8")
    return root


@pytest.mark.parametrize("learner_yaml, reason", [
    ("learner: ann/lee\n",
     "exercises/answers/learner.yaml, line 1: the learner id 'ann/lee' contains a path separator (/ or \\)"),
    ("# my id\nlearner: [ann, lee]\n",
     "exercises/answers/learner.yaml, line 2: `learner:` holds a list, not one id; write `learner: your-id`"),
    ("learner:\n  - ann\n  - lee\n",
     "exercises/answers/learner.yaml, line 2: `learner:` holds a list, not one id; write `learner: your-id`"),
])
def test_quiz_and_submit_give_one_reason_with_file_and_line_for_an_id_they_cannot_use(tmp_path, learner_yaml,
                                                                                       reason):
    root = _project(tmp_path, learner_yaml)
    runner = CliRunner()
    quiz = runner.invoke(main, ["quiz", "ch06", "--submission", str(root)])
    assert quiz.exit_code == 1, quiz.output
    assert f"anonymous (from default; {reason})" in quiz.output.splitlines()[0]
    submit = runner.invoke(main, ["submit", "--submission", str(root)])
    assert submit.exit_code == 2, submit.output
    assert f"no learner id: {reason}, so your quiz was graded with the numbers of 'anonymous'" in " ".join(
        submit.output.split())
    assert "names nobody" not in submit.output
    assert not list(root.glob("*.zip"))


def test_submit_with_an_id_replaces_a_list_in_learner_yaml_whole(tmp_path, monkeypatch):
    from grader.course import submit

    root = _project(tmp_path, "# my id\nlearner:\n  - ann\n  - lee\n# keep this\n")
    monkeypatch.setattr(submit, "pack", lambda *args: (_ for _ in ()).throw(submit.SubmitError("not packed here")))
    done = CliRunner().invoke(main, ["submit", "--submission", str(root), "--learner", "ann"])
    assert "Wrote `learner: ann`" in done.output, done.output
    assert (root / "exercises" / "answers" / "learner.yaml").read_text(encoding="utf-8") == (
        "# my id\nlearner: ann\n# keep this\n")
