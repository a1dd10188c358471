"""Child process of ``test_hostile_fuzz``: runs grammars (JSON lines on stdin) under a memory limit through
``LSystem(...).derive()`` and ``LSystemDocument.set_grammar`` and reports each outcome as a JSON line."""
from __future__ import annotations

import json
import resource
import sys
import time


def main() -> None:
    limit = int(sys.argv[1])
    budget = float(sys.argv[2])
    from plantvr.documents.lsystem import LSystemDocument
    from plantvr.lsystem.engine import LSystem, LSystemError
    LSystemDocument().set_step(3)                           # numba kernels compiled before any budget runs
    doc = LSystemDocument(time_budget=budget, max_modules=2_000_000)
    resource.setrlimit(resource.RLIMIT_AS, (limit, limit))   # after the imports: numba reserves address space
    print(json.dumps({"ready": True}), flush=True)
    for raw in sys.stdin:
        case = json.loads(raw)
        text, trusted = case["text"], case["trusted"]
        for where in ("derive", "document"):
            print(json.dumps({"start": case["i"], "where": where}), flush=True)
            t0 = time.perf_counter()
            out = {"i": case["i"], "where": where, "outcome": "ok", "line": None}
            try:
                if where == "derive":
                    LSystem(text, trusted=trusted, time_budget=budget, max_modules=2_000_000).derive()
                else:
                    before = doc.state_bytes()
                    try:
                        doc.set_grammar(text, trusted=trusted)
                    except BaseException:
                        out["unchanged"] = doc.state_bytes() == before
                        raise
                    doc.undo()
            except LSystemError as e:
                out.update(outcome="LSystemError", line=e.line, message=str(e)[:160])
            except ValueError as e:
                out.update(outcome="ValueError", message=str(e)[:160])
            except BaseException as e:                       # noqa: BLE001 - reported, the parent fails on it
                out.update(outcome=type(e).__name__, message=str(e)[:160])
            out["t"] = time.perf_counter() - t0
            print(json.dumps(out), flush=True)


if __name__ == "__main__":
    main()
