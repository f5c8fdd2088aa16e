"""The README's design-file key reference is what the schema generates, and covers every key."""
from pathlib import Path

from torsal.pipeline.design_file import DesignSpec
from torsal.pipeline.design_reference import readme_section, reference_markdown

README = Path(__file__).resolve().parents[1] / "README.md"


def test_readme_section_is_generated_from_the_schema():
    assert readme_section(README) == reference_markdown(), (
        "README.md design-file keys differ from the schema; run "
        "`.venv/bin/python -m torsal.pipeline.design_reference` and commit README.md")


def _json_schema_keys(schema, node, prefix=""):
    """Every key path of the design file, walked from pydantic's JSON schema (independently of
    the generator's walk over the model fields)."""
    defs = schema.get("$defs", {})

    def resolve(n):
        if "$ref" in n:
            return defs[n["$ref"].split("/")[-1]]
        for alt in n.get("anyOf", []):
            if "$ref" in alt or alt.get("type") == "array":
                return resolve(alt)
        return n

    out = []
    for name, sub in node.get("properties", {}).items():
        path = prefix + name
        out.append(path)
        target = resolve(sub)
        if target.get("type") == "array" and "$ref" in target.get("items", {}):
            target = resolve(target["items"])
            if target.get("title") != "Region":
                out += _json_schema_keys(schema, target, path + "[].")
        elif "properties" in target and target.get("title") != "Region":
            out += _json_schema_keys(schema, target, path + ".")
    return out


def test_every_key_of_the_schema_is_in_the_reference():
    schema = DesignSpec.model_json_schema()
    table = reference_markdown()
    keys = _json_schema_keys(schema, schema)
    assert len(keys) > 70
    missing = [k for k in keys if f"| `{k}` |" not in table]
    assert not missing
    # every row has a type and a default; lengths say their unit
    for line in table.splitlines():
        if line.startswith("| `") and any(w in line for w in ("spacing", "depth", "offset")):
            assert "model units" in line, line
