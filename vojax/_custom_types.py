"""jaxtyping aliases used on public signatures."""

from jaxtyping import Array, ArrayLike, Float

Samples = Float[ArrayLike, "N"] | Float[ArrayLike, "N n"]
OrderLike = float | Float[ArrayLike, ""] | Float[ArrayLike, "N"]
SampledOrder = Float[Array, " N"]

__all__ = ["Array", "ArrayLike", "Float", "OrderLike", "SampledOrder", "Samples"]
