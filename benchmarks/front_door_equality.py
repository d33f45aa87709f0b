"""Identification results of six fixed cases, written to a JSON file (argument), to compare
the front door of identification before and after a refactoring: run it on both commits and
compare the files (NaN equals NaN).  Cases: the paper case by the PINN (one and three members,
short trainings) and by the field route; field cases (E-Defense accelerometers, Table 1 sparse,
an 8-member ensemble)."""
import sys, json
try:
    from pier_monitor.core.identify.methods import identify, IdentifySettings as S
except ImportError:
    from pier_monitor.pinn import identify, PinnSettings as S
from pier_monitor.core.synthetic.reference import paper_case_window
from pier_monitor.bench import field_case
import torch; torch.set_num_threads(1)
out = {}
WHAT = ("identification results (result.json content less wall time and settings) of six "
        "cases with every deciding setting given; produced by "
        "benchmarks/front_door_equality.py: run it before and after a refactoring and compare "
        "(NaN equals NaN)")
w, truth, _ = paper_case_window(seed=0)
# every setting that decides the result given (members too: the defaults may change)
cases = [("pinn1", w, dict(method="pinn", max_epochs=60, min_epochs=10, members=1)),
         ("pinn3", w, dict(method="pinn", max_epochs=40, min_epochs=10, members=3)),
         ("paper_field", w, dict(method="field", members=1))]
for pier, layout, m in [("edefense", "accel", 1), ("table1", "sparse", 1), ("edefense", "accel", 8)]:
    cases.append((f"{pier}_{layout}_{m}", field_case(pier, layout, False, "strong", 1)[0], dict(members=m)))
for name, win, kw in cases:
    r = identify(win, getattr(S, "from_flat", S)(**kw))  # flat keywords, before and after
    d = r.result.to_dict(); d.pop("wall_time_s", None); d.pop("settings", None)
    out[name] = d
    print(name, r.result.overall_state, file=sys.stderr)
json.dump({"what": WHAT, "cases": out}, open(sys.argv[1], "w"), indent=1, default=str)
