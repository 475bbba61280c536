"""The shipped configs as some tests read them."""


def plain_uniform(data: dict) -> dict:
    """A shipped shell config's ``data`` (parsed YAML) planned uniformly and without an
    objective: the plain layout of equal strakes and equal butts, no plate run to plan it
    (an objective lays a yard's staggered butts even in a uniform plan), nothing planned
    again (``plan.replan_held`` plans an adaptive plan again after its fit-up)."""
    plan = data["strake"]["plan"]
    plan["method"] = "uniform"
    plan.pop("objective", None)
    plan.pop("replan_held", None)
    return data


def with_files_from(data: dict, folder) -> dict:
    """A shipped config's ``data`` with every file it names (the hull's surfaces, deck curves)
    made absolute from ``folder``, the config's own folder: the config can then be written
    anywhere."""
    from pathlib import Path

    strake = data["strake"]
    sources = [strake["surface"], *strake.get("plan", {}).get("surfaces", [])]
    sources += [deck["curve"] for deck in strake.get("decks", []) if "curve" in deck]
    for source in sources:
        for key in ("iges", "model", "dxf"):
            if key in source:
                source[key] = str((Path(folder) / source[key]).resolve())
    return data
