"""docs/rules.md is generated (tools/gen_rule_ledger.py) and must match the code and tests."""
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tools"))

import gen_rule_ledger  # noqa: E402

from pndiss import rules  # noqa: E402


def test_ledger_is_not_stale():
    with open(gen_rule_ledger.OUT, encoding="utf-8") as f:
        assert f.read() == gen_rule_ledger.build(), "docs/rules.md is stale: run python3 tools/gen_rule_ledger.py"


def test_ledger_covers_all_92_rules_and_every_rule_has_a_status():
    text = gen_rule_ledger.build()
    rows = [l for l in text.splitlines() if l.startswith("| ") and "`" in l]
    assert len(rows) == 92 == len(rules.RULES)
    assert all(("implemented" in r) or ("not decidable" in r) or ("| open |" in r) for r in rows)


def test_rule_ids_named_in_the_checker_exist():
    code = gen_rule_ledger._scan("pndiss/encoder")
    ids = {k for k in code if k.isupper() and "-" in k and not k.startswith("0X")}
    assert ids and ids <= set(rules.RULES), ids - set(rules.RULES)
