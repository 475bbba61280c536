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
