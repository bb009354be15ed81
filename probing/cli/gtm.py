"""``probing modes`` and ``gtm-damage``: the GTM's mode table and NASA's damage cases."""

from __future__ import annotations

import argparse
from pathlib import Path

from probing.cli.common import Subcommands, command, out_file, out_folder, path_arg, simulating

#: Where ``probing modes`` writes by default: the committed page and figure
#: (``docs/gtm.md``, ``figures/gtm_modes.png``) only when named (``make modes``).
MODES_OUT = Path("results/modes")


def _cmd_modes(args: argparse.Namespace) -> int:
    out_file(args.docs, "--docs")
    out_file(args.figure.with_name(f"{args.figure.name}.png"), "--figure")

    def job() -> int:
        from probing.analysis import gtm_modes
        from probing.experiment.studies.modes import damage_table, mode_table

        points = mode_table()
        damage = damage_table()
        print(gtm_modes.mode_table(points))
        for p in points:
            if p.modes is not None:
                eigs = ", ".join(f"{e:.4f}" for e in p.modes.eigenvalues)
                print(f"{p.ve_kts:.0f} kt eigenvalues: {eigs}")
        print(gtm_modes.damage_level_table(damage))
        gtm_modes.write_doc(points, args.docs, damage)
        (path,) = gtm_modes.save(points, args.figure)
        print(f"wrote {args.docs} and {path}")
        return 0

    return simulating(job, "gtm_t2")


def _cmd_gtm_damage(args: argparse.Namespace) -> int:
    if args.figures is None:
        args.figures = args.out / "figures"
    out_folder(args.out, "--out")
    out_file(args.out / "summary.csv", "--out")
    out_folder(args.figures, "--figures")

    def job() -> int:
        from probing.analysis import gtm_damage
        from probing.experiment.studies.gtm_damage import run_example6

        run_example6(args.out)
        cases = gtm_damage.load(args.out)
        table = gtm_damage.summary(cases)
        table.to_csv(args.out / "summary.csv", index=False)
        trim = gtm_damage.trim_table(cases)
        trim.to_csv(args.out / "trim.csv", index=False)
        paths = gtm_damage.draw(cases, args.figures)
        print(trim.set_index("trim").T.to_string())
        cols = ["case", "name", "phi_deg_end", "beta_deg_min", "beta_deg_max", "r_deg_s_end"]
        print(table[cols].to_string(index=False))
        for path in paths:
            print(f"figure -> {path}")
        print(f"summary -> {args.out / 'summary.csv'}, trim -> {args.out / 'trim.csv'}")
        return 0

    return simulating(job, "gtm_t2")


def register(sub: Subcommands) -> None:
    """Add ``modes`` and ``gtm-damage`` to ``sub``."""
    modes = command(
        sub,
        "modes",
        "trim and linearise the GTM at 800 ft, 60..130 KEAS; write the mode table and figure",
        [
            "probing modes   # into results/modes/",
            "probing modes --docs docs/gtm.md --figure figures/gtm_modes   # what make modes runs",
        ],
    )
    modes.add_argument(
        "--docs",
        type=path_arg,
        default=MODES_OUT / "gtm.md",
        help="page written whole (the committed one: docs/gtm.md)",
    )
    modes.add_argument(
        "--figure",
        type=path_arg,
        default=MODES_OUT / "gtm_modes",
        help="figure, without .png (the committed one: figures/gtm_modes)",
    )
    modes.set_defaults(func=_cmd_modes)

    damage = command(
        sub,
        "gtm-damage",
        "NASA's Example 6: each GTM damage case at 10 s of a 45 deg bank climbing turn",
        [
            "probing gtm-damage   # into results/gtm_damage/",
            "probing gtm-damage --figures figures   # what make gtm-damage runs",
        ],
    )
    damage.add_argument(
        "--out", type=path_arg, default=Path("results/gtm_damage"), help="time histories, summary"
    )
    damage.add_argument(
        "--figures",
        type=path_arg,
        default=None,
        help="figure folder (default: OUT/figures; the committed ones: figures)",
    )
    damage.set_defaults(func=_cmd_gtm_damage)
