"""Architecture of a frozen MLP as a bundle manifest declares it (``mlps.<m>``), and the
names and shapes of its tensors (docs/learned_predictors.md)."""
from __future__ import annotations

from dataclasses import dataclass

ACTIVATIONS = ("tanh", "relu")
NORM_NAMES = ("in_mean", "in_scale", "out_mean", "out_scale")


class MLPError(ValueError):
    """Tensors that do not make the declared MLP (missing, misshapen, non-finite)."""


@dataclass(frozen=True)
class MLPSpec:
    """Architecture of one MLP, as a bundle manifest declares it (``mlps.<m>``)."""

    activation: str  # hidden-layer activation, "tanh" or "relu"; the last layer is linear
    layers: tuple[int, ...]  # widths, input first, output last (at least 2 entries)
    inputs: str = "pose-v1"  # feature layout of the inputs (see impactnet.models.learned.canonical)
    outputs: str = "contact-v1"  # meaning of the outputs (contact-v1, contact-residual-v1)

    def __post_init__(self) -> None:
        if self.activation not in ACTIVATIONS:
            raise MLPError(f"activation must be one of {ACTIVATIONS}, got {self.activation!r}")
        layers = tuple(self.layers) if isinstance(self.layers, list | tuple) else ()
        if len(layers) < 2 or not all(isinstance(w, int) and not isinstance(w, bool) and w >= 1
                                      for w in layers):
            raise MLPError(f"layers must be >= 2 positive ints, got {self.layers!r}")
        object.__setattr__(self, "layers", layers)

    @classmethod
    def from_dict(cls, entry) -> MLPSpec:
        """The spec of a manifest entry ``{"activation", "layers", "inputs", "outputs"}``."""
        if not isinstance(entry, dict) or not {"activation", "layers"} <= set(entry):
            raise MLPError(f"an MLP entry needs 'activation' and 'layers', got {entry!r}")
        extra = set(entry) - {"activation", "layers", "inputs", "outputs"}
        if extra:
            raise MLPError(f"unknown MLP keys {sorted(extra)}")
        return cls(entry["activation"], entry["layers"], entry.get("inputs", "pose-v1"),
                   entry.get("outputs", "contact-v1"))

    def to_dict(self) -> dict:
        return {"activation": self.activation, "layers": list(self.layers),
                "inputs": self.inputs, "outputs": self.outputs}

    def shapes(self, name: str) -> dict[str, tuple[int, ...]]:
        """Tensor name -> shape of an MLP called ``name`` with this architecture."""
        shapes = {}
        for k, (n_in, n_out) in enumerate(zip(self.layers[:-1], self.layers[1:])):
            shapes[f"{name}.w{k}"] = (n_out, n_in)
            shapes[f"{name}.b{k}"] = (n_out,)
        for norm in NORM_NAMES:
            shapes[f"{name}.{norm}"] = (self.layers[0] if norm.startswith("in") else
                                        self.layers[-1],)
        return shapes
