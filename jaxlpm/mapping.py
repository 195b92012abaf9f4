"""Members of a batch mapped one at a time or in vmapped groups."""

import jax


def map_in_groups(fun, xs, width):
    """`lax.map` of fun over xs' leading axis in vmapped groups of `width` members; width 1
    (or None) runs the members one at a time, not vmapped: a vmap, even of one member, turns
    every `lax.cond` of an iterative solver into a select that runs both branches."""
    return jax.lax.map(fun, xs, batch_size=None if width in (None, 1) else width)
