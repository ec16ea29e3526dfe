"""``[strength]``: what each tissue layer and the thread can bear, for ``suture-fem holding``.

Each layer has a failure stress (``<layer>_pa``, compared with its critical-distance von Mises stress
``seqv_cd_pa``) and a failure strain (``<layer>_strain``, an equivalent Hencky strain compared with
``eptoeqv_cd``); ``criterion`` picks which one decides. The thread breaks at ``thread_break_n``. Each
value has a band (``*_band``: the published spread as factors of the value, low <= 1 <= high), from
which :mod:`suture_fem.studies.holding` gives the holding force's band. The values and their sources
are in ``defaults.toml``; nothing in the model's solve reads them.
"""

from __future__ import annotations

from dataclasses import fields

from suture_fem.geometry.regions import TISSUE_REGIONS
from suture_fem.scene.schema import PA, N, Rule, _pos, _Section, key, section
from suture_fem.support.errors import SceneError

#: The layers that can tear (the suture's own failure is the thread's breaking force).
LAYERS = TISSUE_REGIONS
#: A failure strain below this lies in soft tissue's toe region, where no tissue tears: refused.
MIN_FAILURE_STRAIN = 0.05
_STRAIN = Rule("float", lo=MIN_FAILURE_STRAIN, hi=10.0)
_BAND = Rule("floats", lo=0.0, hi=100.0, lo_open=True)


@section("strength")
class StrengthSection(_Section):
    """``[strength]``: failure stress and strain per tissue layer, the thread's breaking force, their bands."""

    criterion: str = key(Rule("str", choices=("stress", "strain")))
    hypodermis_pa: float = key(_pos(1e10), PA)
    hypodermis_band: tuple[float, ...] = key(_BAND)
    dermis_pa: float = key(_pos(1e10), PA)
    dermis_band: tuple[float, ...] = key(_BAND)
    epidermis_pa: float = key(_pos(1e10), PA)
    epidermis_band: tuple[float, ...] = key(_BAND)
    hypodermis_strain: float = key(_STRAIN)
    hypodermis_strain_band: tuple[float, ...] = key(_BAND)
    dermis_strain: float = key(_STRAIN)
    dermis_strain_band: tuple[float, ...] = key(_BAND)
    epidermis_strain: float = key(_STRAIN)
    epidermis_strain_band: tuple[float, ...] = key(_BAND)
    thread_break_n: float = key(_pos(1e4), N)
    thread_break_band: tuple[float, ...] = key(_BAND)

    def __post_init__(self) -> None:
        super().__post_init__()
        for f in fields(self):  # type: ignore[arg-type]
            if f.name.endswith("band"):
                band = getattr(self, f.name)
                if len(band) != 2 or not band[0] <= 1.0 <= band[1]:
                    raise SceneError(f"scene key strength.{f.name} = {list(band)}: expected [low, high] factors of "
                                     "the value with 0 < low <= 1 <= high <= 100, e.g. [0.6, 1.4]")

    def of(self, layer: str) -> tuple[float, tuple[float, float]]:
        """A layer's strength under the criterion (Pa, or an equivalent strain) and its band factors."""
        suffix = "_pa" if self.criterion == "stress" else "_strain"
        band = getattr(self, f"{layer}_band" if self.criterion == "stress" else f"{layer}_strain_band")
        return float(getattr(self, layer + suffix)), (float(band[0]), float(band[1]))
