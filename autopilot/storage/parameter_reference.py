"""The parameter reference of docs/mavlink.md section 9, generated from the parameter table:

    python -m autopilot.storage.parameter_reference > table.md

prints the markdown table (one row per parameter, in the table's order, which is PARAM_VALUE's param_index).
tests/unit/test_gains.py checks that the docs hold it as printed.
"""

from __future__ import annotations

from autopilot.storage.parameters import DEFINITIONS, INT32, ParameterDefinition

HEADER = ("| name | type | default | range | unit | PX4 | meaning |\n"
          "| --- | --- | --- | --- | --- | --- | --- |")  # fmt: skip


def _number(definition: ParameterDefinition, value: float) -> str:
    return str(int(value)) if definition.kind == INT32 else f"{value:.6g}"


def row(definition: ParameterDefinition) -> str:
    d = definition
    return (f"| `{d.name}` | {d.kind} | {_number(d, d.default)} | {_number(d, d.minimum)} … {_number(d, d.maximum)} "
            f"| {d.unit} | {'yes' if d.px4 else 'ours'} | {d.description} |")  # fmt: skip


def markdown_table(definitions: tuple[ParameterDefinition, ...] = DEFINITIONS) -> str:
    return "\n".join((HEADER, *(row(d) for d in definitions)))


def main() -> None:
    print(markdown_table())


if __name__ == "__main__":
    main()
