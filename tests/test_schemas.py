"""The JSON Schemas shipped in grader/schemas: valid draft 2020-12 schemas, one per JSON the grader writes,
strict (an undocumented field fails), and what `grade ... --format json` and `grade quiz ... --format json`
print validates against them. (report.json and results.json of grade batch: test_lms_outputs; results.json
of the Gradescope autograder: test_gradescope; grade classroom: test_classroom.)"""

from __future__ import annotations

import json

import pytest
from click.testing import CliRunner

from grader.faces.cli import main
from grader.render import lms

jsonschema = pytest.importorskip("jsonschema")


def _validator(name: str):
    from referencing import Registry, Resource

    registry = Registry().with_resources((lms.schema(n)["$id"], Resource.from_contents(lms.schema(n)))
                                         for n in lms.SCHEMAS)
    return jsonschema.Draft202012Validator(lms.schema(name), registry=registry)


def test_every_schema_is_a_valid_schema_and_every_file_is_listed():
    files = sorted(p.name.removesuffix(".schema.json") for p in lms.SCHEMA_DIR.glob("*.schema.json"))
    assert files == sorted(lms.SCHEMAS)
    for name in lms.SCHEMAS:
        schema = lms.schema(name)
        jsonschema.Draft202012Validator.check_schema(schema)
        assert schema["$id"].endswith(f"/{name}.schema.json") and schema["additionalProperties"] is False


@pytest.fixture(scope="module")
def reports():
    runner = CliRunner()
    solutions = runner.invoke(main, ["ch06", "ch09", "--solutions", "--format", "json"])
    stubs = runner.invoke(main, ["ch06", "--submission", str(lms.SCHEMA_DIR.parents[1]), "--format", "json"])
    quiz = runner.invoke(main, ["quiz", "ch06", "--solutions", "--format", "json"])
    no_quiz = runner.invoke(main, ["ch03", "--solutions", "--no-quiz", "--format", "json"])
    return {name: json.loads(result.output) for name, result in
            (("solutions", solutions), ("stubs", stubs), ("quiz", quiz), ("no_quiz", no_quiz))}


@pytest.mark.parametrize("name", ["solutions", "stubs", "quiz", "no_quiz"])
def test_grade_format_json_validates(reports, name):
    _validator("report").validate(reports[name])


def test_the_schema_says_what_each_command_prints(reports):
    assert reports["quiz"]["seed"] is None and isinstance(reports["solutions"]["seed"], int)
    assert reports["no_quiz"]["learner"] is None and reports["solutions"]["learner"].endswith(")")
    statuses = {c["status"] for ch in reports["stubs"]["chapters"] for c in ch["checks"]}
    allowed = set(lms.schema("report")["$defs"]["check"]["properties"]["status"]["enum"])
    assert statuses <= allowed


@pytest.mark.parametrize("where", ["top", "chapter", "check"])
def test_an_undocumented_field_fails_validation(reports, where):
    data = json.loads(json.dumps(reports["solutions"]))
    target = {"top": data, "chapter": data["chapters"][0], "check": data["chapters"][0]["checks"][0]}[where]
    target["undocumented"] = 1
    with pytest.raises(jsonschema.ValidationError, match="undocumented"):
        _validator("report").validate(data)
