"""Rope presets: real ropes whose bending and torsional stiffness are independent of their axial
stiffness.

A solid isotropic rod has ``EA h^2 / EI = 4``; a rope is a bundle of thin fibres that bend almost
independently of one another while they all carry the tension, so that ``EA h^2 / EI`` is of order
10^2 to 10^4 (docs/physics.md, "Ropes that exist"). Each :class:`RopePreset` holds one rope's
diameter, linear density, ``EA``, ``EI``, ``GJ`` and friction coefficients, each with the source
it comes from; a number that no source measures is derived from cited facts and its citation
string says so (``"derived: ..."``), and an assumption says ``"assumed: ..."``. The references are
listed in docs/bibliography.md.

Use a preset with the protocol parameter ``rope`` (``knotsim pull KNOT --rope NAME``), or build a
rod from one with :meth:`RopePreset.rod_kwargs`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from knotsim.errors import ConfigError

#: Standard gravity, m/s^2 (EN 892 loads are masses).
G_STANDARD = 9.80665


@dataclass(frozen=True)
class RopePreset:
    """One real rope (SI units).

    Parameters
    ----------
    name:
        Short name used on the command line (``--rope NAME``).
    description:
        One line: what rope this is.
    diameter:
        Nominal diameter ``2 h``, m.
    linear_density:
        Mass per unit length ``lambda``, kg/m.
    EA:
        Axial stiffness (force per unit strain), N.
    EI:
        Bending stiffness, N m^2.
    GJ:
        Torsional stiffness, N m^2.
    mu:
        Kinetic (sliding) Coulomb friction coefficient of the rope on itself.
    mu_static:
        Static friction coefficient (>= ``mu``), used by the elastic-stick friction law.
    sources:
        Where each number comes from: a mapping from the field name (``diameter``,
        ``linear_density``, ``EA``, ``EI``, ``GJ``, ``mu``, ``mu_static``) to a citation string
        (a reference of docs/bibliography.md, or ``"derived: ..."`` / ``"assumed: ..."``), as a
        tuple of ``(field, text)`` pairs so that the preset stays hashable.
    """

    name: str
    description: str
    diameter: float
    linear_density: float
    EA: float
    EI: float
    GJ: float
    mu: float
    mu_static: float
    sources: tuple[tuple[str, str], ...]

    @property
    def radius(self) -> float:
        """Radius ``h``, m."""
        return 0.5 * self.diameter

    @property
    def area(self) -> float:
        """Area of the circle of the nominal diameter, ``pi h^2``, m^2."""
        return math.pi * self.radius**2

    @property
    def density(self) -> float:
        """Effective mass density ``lambda / (pi h^2)``, kg/m^3 (what a rod of radius ``h`` needs to
        have this rope's linear density)."""
        return self.linear_density / self.area

    @property
    def youngs_modulus(self) -> float:
        """Effective Young's modulus ``EA / (pi h^2)``, Pa (gives a rod of radius ``h`` this rope's EA)."""
        return self.EA / self.area

    @property
    def stiffness_ratio(self) -> float:
        """``EA h^2 / EI`` (4 for a solid isotropic rod, 10^2 to 10^4 for a fibrous rope)."""
        return self.EA * self.radius**2 / self.EI

    def tension_ratio(self, tension: float) -> float:
        """``T h^2 / EI`` at tension ``T`` (N): well above 1, the rope is in the string regime."""
        return tension * self.radius**2 / self.EI

    def source(self, field: str) -> str:
        """The citation string of ``field`` (``"EI"``, ``"mu"``, ...)."""
        return dict(self.sources)[field]

    def rod_kwargs(self) -> dict[str, float]:
        """Keyword arguments of :class:`knotsim.rods.RodSpec` for this rope: ``radius`` (m),
        ``density`` (kg/m^3), ``youngs_modulus`` (Pa), ``bending_stiffness`` and
        ``torsional_stiffness`` (N m^2)."""
        return {"radius": self.radius, "density": self.density, "youngs_modulus": self.youngs_modulus,
                "bending_stiffness": self.EI, "torsional_stiffness": self.GJ}


def bundle_bending_stiffness(fibre_modulus: float, fibre_area: float, fibre_diameter: float) -> float:
    """EI (N m^2) of ``n`` parallel fibres of diameter ``d`` (m) that bend independently, each about
    its own axis: ``n E_f pi d^4 / 64 = E_f A_f d^2 / 16`` with ``A_f = n pi d^2 / 4`` the fibres'
    total cross-section (m^2) and ``E_f`` their Young's modulus (Pa)."""
    return fibre_modulus * fibre_area * fibre_diameter**2 / 16.0


def filament_diameter(linear_density: float, fibre_density: float) -> float:
    """Diameter (m) of a round filament of ``linear_density`` kg/m (1 dtex = 1e-7 kg/m) and
    material density ``fibre_density`` kg/m^3."""
    return math.sqrt(4.0 * linear_density / (math.pi * fibre_density))


# --------------------------------------------------------------------------- cited inputs
DTEX = 1e-7  # kg/m
#: nylon (polyamide 66, high-tenacity industrial yarn): density 1.14 g/cm^3, initial modulus 82 cN/dtex
#: [Teijin, tensile properties of industrial fibres]
_NYLON_DENSITY = 1140.0
_NYLON_MODULUS = 0.82 / DTEX * _NYLON_DENSITY  # 82 cN/dtex = 0.82 N/dtex -> Pa: 9.3 GPa
#: assumed filament of a nylon rope yarn: 6.7 dtex (e.g. a 940 dtex yarn of 140 filaments)
_NYLON_FILAMENT = filament_diameter(6.7 * DTEX, _NYLON_DENSITY)  # 27 um
#: nylon on nylon, static 0.15-0.25 [Engineering ToolBox, friction coefficients]
_NYLON_MU, _NYLON_MU_STATIC = 0.15, 0.25
#: Poisson ratio of the assumption GJ = EI / (1 + nu) (isotropic fibres twisting independently);
#: 0.5 keeps knotsim's solid-rod ratio EI / GJ = 1.5
_NU = 0.5

# 10 mm single dynamic rope (EN 892)
_K_D = 10.0e-3
_K_LAMBDA = 0.065  # kg/m, within Mammut's 60-85 g/m of single ropes
_K_STRAIN = 0.08  # static elongation at 80 kg after a 5 kg preload (EN 892 limit 10 %)
_K_EA = (80.0 - 5.0) * G_STANDARD / _K_STRAIN
_K_FIBRE_AREA = _K_LAMBDA / _NYLON_DENSITY
_K_EI = bundle_bending_stiffness(_NYLON_MODULUS, _K_FIBRE_AREA, _NYLON_FILAMENT)
_K_PACKING = _K_FIBRE_AREA / (math.pi * (_K_D / 2) ** 2)

# 4 mm nylon kernmantle accessory cord (EN 564)
_C_D = 4.0e-3
_C_LAMBDA = _K_PACKING * _NYLON_DENSITY * math.pi * (_C_D / 2) ** 2
_C_EA = _K_EA / _K_LAMBDA * _C_LAMBDA
_C_EI = bundle_bending_stiffness(_NYLON_MODULUS, _C_LAMBDA / _NYLON_DENSITY, _NYLON_FILAMENT)

# USP 2-0 nylon monofilament suture: a solid rod
_S_D = 0.5 * (0.300e-3 + 0.339e-3)  # the middle of USP 2-0's 0.300-0.339 mm
_S_E = 2.5e9  # assumed modulus of a drawn nylon monofilament
_S_AREA = math.pi * (_S_D / 2) ** 2
_S_I = math.pi * (_S_D / 2) ** 4 / 4

# PE #1 braided fishing line (UHMWPE, e.g. Dyneema SK75)
_B_LAMBDA = 200e-3 / 9000.0  # 200 denier = 200 g per 9000 m (JAFS: PE #1 = 200 d)
_B_FIBRE_DENSITY = 975.0  # 0.97-0.98 g/cm^3 [DSM]
_B_FIBRE_MODULUS = 120e9  # SK75: 109-132 GPa [DSM]
_B_FILAMENT = filament_diameter(2.2 * DTEX, _B_FIBRE_DENSITY)  # 2.2 dtex filaments [DSM]: 17 um
_B_FIBRE_AREA = _B_LAMBDA / _B_FIBRE_DENSITY
_B_PACKING = 0.7  # assumed fibre packing fraction of the braid
_B_D = math.sqrt(4.0 * _B_FIBRE_AREA / (math.pi * _B_PACKING))
_B_EA = _B_FIBRE_MODULUS * _B_FIBRE_AREA
_B_EI = bundle_bending_stiffness(_B_FIBRE_MODULUS, _B_FIBRE_AREA, _B_FILAMENT)

_NYLON_EI_TEXT = ("derived: {n} nylon filaments of 27 um bending independently, EI = E_f A_f d^2/16 with E_f = "
                  "9.3 GPa (82 cN/dtex x 1.14 g/cm^3 [Teijin]), A_f = linear density / 1140 kg/m^3; filament "
                  "6.7 dtex assumed (a 940 dtex f140 industrial yarn); a lower bound (fibre friction and the "
                  "braid stiffen a real rope)")
_GJ_TEXT = ("assumed: GJ = EI / (1 + nu), nu = 0.5 (fibres twisting independently as isotropic rods; "
            "no measured torsional stiffness)")
_NYLON_MU_TEXT = "nylon on nylon, the lower end of the static 0.15-0.25 [Engineering ToolBox], taken as kinetic"
_NYLON_MUS_TEXT = "nylon on nylon, the upper end of the static 0.15-0.25 [Engineering ToolBox]"

ROPE_PRESETS: dict[str, RopePreset] = {p.name: p for p in (
    RopePreset(
        name="dynamic-10mm",
        description="10 mm single dynamic climbing rope, nylon kernmantle (EN 892)",
        diameter=_K_D, linear_density=_K_LAMBDA, EA=_K_EA, EI=_K_EI, GJ=_K_EI / (1 + _NU),
        mu=_NYLON_MU, mu_static=_NYLON_MU_STATIC,
        sources=(
            ("diameter", "nominal; EN 892 measures it under 10 kg [Mammut, standards for dynamic ropes]"),
            ("linear_density", "65 g/m, within the 60-85 g/m of single ropes [Mammut, standards for dynamic ropes]"),
            ("EA", "derived: EN 892 static elongation (5 kg preload, then 80 kg) [Edelrid, EN 892 summary], "
                   "taken as 8 % (up to 8 % [BeSafety manual]; limit 10 % [Petzl, elongation]): "
                   "EA = 75 kg x 9.81 m/s^2 / 0.08"),
            ("EI", _NYLON_EI_TEXT.format(n=f"{_K_FIBRE_AREA / (math.pi * _NYLON_FILAMENT**2 / 4):.0f}")),
            ("GJ", _GJ_TEXT),
            ("mu", _NYLON_MU_TEXT),
            ("mu_static", _NYLON_MUS_TEXT),
        )),
    RopePreset(
        name="cord-4mm",
        description="4 mm nylon kernmantle accessory cord (EN 564, at least 3.2 kN)",
        diameter=_C_D, linear_density=_C_LAMBDA, EA=_C_EA, EI=_C_EI, GJ=_C_EI / (1 + _NU),
        mu=_NYLON_MU, mu_static=_NYLON_MU_STATIC,
        sources=(
            ("diameter", "nominal; EN 564 sizes 4-8 mm, 4 mm at least 3.2 kN [Singing Rock, EN 564]"),
            ("linear_density", f"derived: the 10 mm rope's fibre packing ({_K_PACKING:.2f} of the circle, nylon "
                               "1140 kg/m^3) at 4 mm"),
            ("EA", "derived: the 10 mm rope's EA per unit linear density (same nylon kernmantle construction) "
                   "times this cord's linear density"),
            ("EI", _NYLON_EI_TEXT.format(n=f"{_C_LAMBDA / _NYLON_DENSITY / (math.pi * _NYLON_FILAMENT**2 / 4):.0f}")),
            ("GJ", _GJ_TEXT),
            ("mu", _NYLON_MU_TEXT),
            ("mu_static", _NYLON_MUS_TEXT),
        )),
    RopePreset(
        name="suture-2-0",
        description="USP 2-0 nylon monofilament suture: a solid rod (EA h^2/EI = 4)",
        diameter=_S_D, linear_density=_NYLON_DENSITY * _S_AREA, EA=_S_E * _S_AREA, EI=_S_E * _S_I,
        GJ=_S_E / (2 * (1 + _NU)) * 2 * _S_I, mu=_NYLON_MU, mu_static=_NYLON_MU_STATIC,
        sources=(
            ("diameter", "the middle of USP 2-0's 0.300-0.339 mm [USP <861>]"),
            ("linear_density", "derived: solid nylon, 1140 kg/m^3 [Teijin] x pi h^2"),
            ("EA", "derived: E pi h^2 with E = 2.5 GPa, assumed for a drawn nylon monofilament (between bulk "
                   "nylon and the 9.3 GPa of high-tenacity yarn [Teijin]); 3-0 nylon breaks at 31 N "
                   "[Naleway 2015]"),
            ("EI", "derived: solid rod, E pi h^4 / 4"),
            ("GJ", "derived: solid rod, G pi h^4 / 2 with G = E / (2 (1 + nu)), nu = 0.5 (assumed)"),
            ("mu", _NYLON_MU_TEXT),
            ("mu_static", _NYLON_MUS_TEXT),
        )),
    RopePreset(
        name="braid-pe1",
        description="PE #1 braided fishing line, UHMWPE (Dyneema-type) fibres, 200 denier",
        diameter=_B_D, linear_density=_B_LAMBDA, EA=_B_EA, EI=_B_EI, GJ=_B_EI / (1 + _NU),
        mu=0.05, mu_static=0.05,
        sources=(
            ("diameter", f"derived: fibre cross-section 200 denier / 975 kg/m^3 over an assumed packing fraction "
                         f"{_B_PACKING} (the printed 'PE #1' diameters are nominal)"),
            ("linear_density", "PE #1 = 200 denier = 200 g per 9000 m [JAFS PE line standard]"),
            ("EA", "derived: E_f A_f with E_f = 120 GPa (SK75: 109-132 GPa [DSM fact sheet]), braid angle "
                   "neglected; with 3.4-4.0 N/tex [DSM] it breaks at 3 % strain, as the fibre (3-4 %)"),
            ("EI", f"derived: {_B_FIBRE_AREA / (math.pi * _B_FILAMENT**2 / 4):.0f} UHMWPE filaments of 2.2 dtex "
                   "(17 um) [DSM] bending independently, EI = E_f A_f d^2/16"),
            ("GJ", _GJ_TEXT),
            ("mu", "derived: UHMWPE fibre friction is below PTFE's [Marissen 2011], PTFE on PTFE 0.04 [Serway & Jewett]; "
                   "taken as 0.05"),
            ("mu_static", "assumed equal to mu (no source for a static excess)"),
        )),
)}


def rope_presets() -> dict[str, RopePreset]:
    """The rope presets by name (a copy of :data:`ROPE_PRESETS`)."""
    return dict(ROPE_PRESETS)


def get_rope(name: str, field: str = "rope") -> RopePreset:
    """The preset called ``name``; an unknown name raises :class:`ConfigError` naming ``field`` and
    listing the presets."""
    if not isinstance(name, str) or name not in ROPE_PRESETS:
        raise ConfigError(field, f"unknown rope {name!r}; the presets are {', '.join(ROPE_PRESETS)} "
                                 "(knotsim ropes lists them)")
    return ROPE_PRESETS[name]
