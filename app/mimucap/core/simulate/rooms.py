"""Rooms for the simulated subject: magnetic fields that change with position.

Real rooms are not magnetically clean. The field near a reinforced floor, a steel bed or a
treadmill differs from the earth field by tens of µT over a metre, and the feet see it first.
de Vries, Veeger, Baten and van der Helm ("Magnetic distortion in motion labs, implications
for validating inertial magnetic sensors", Gait & Posture 2009) mapped a motion lab: the
heading of the measured field scattered with a standard deviation of 29° at 5 cm above the
floor, falling to 3° above 100 cm. Bachmann, Yun and Peterson ("An investigation
of the effects of magnetic variations on inertial/magnetic orientation sensors", ICRA 2004)
found that the field deviation near ferrous objects (furniture, appliances) falls off within
a few tenths of a metre, so that keeping about 0.6 m (two feet) away makes it small.

Presets (:data:`ROOMS`, names in :data:`mimucap.core.simulate.names.ROOM_NAMES`):

* ``clean``: the earth field alone (the simulator's default, unchanged);
* ``clinic``: a reinforced floor whose field decays with height as de Vries et al. measured
  (about 21 µT at the feet, 3 µT at the pelvis), and a steel hospital bed beside the walkway
  (:data:`BED_CENTRE_M`), which the demo's walk passes on the way out and on the way back
  (more than 40 µT at the sensors that pass within half a metre of it);
* ``treadmill``: the walking happens on a treadmill whose steel frame, rollers and drive
  motor lie under the belt (more than 30 µT at the feet throughout the walking).

Where the subject stands: every scenario starts at the world origin facing north (+y), with
the feet on the floor (``clinic``) or on the belt (``treadmill``). The magnetometer turns of a
session's start happen there, with the units held at hand height (1.05 m, 0.35 m in front of
the pelvis), where the floor adds only a few µT and the bed is more than 2.5 m away, as a
clinician calibrates away from metal; on the treadmill they happen on the belt, at hand height,
where the frame and motor add about 18 µT (this room has no place away from the treadmill).

The floor is modelled as a sum of spatial harmonics of the field's scalar potential (sources
below the floor): a harmonic of wavenumber k has a constant magnitude at a given height and
decays as ``exp(-k z)``, which gives de Vries et al.'s fall from 29° to 3° between 5 cm and
100 cm for k of about 2.3 per metre. Steel objects are clusters of magnetic
dipoles (moments in A·m², ``B = µ0/4π · (3 (m·r̂) r̂ − m) / r³``).

Frames: world ENU (x east, y north, z up, z = 0 on the floor or belt); positions in m; fields
in µT (world frame, added to the earth field).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: µ0 / 4π in µT·m/A: a dipole of 1 A·m² gives 0.2 µT on its axis and 0.1 µT across it at 1 m.
MU0_OVER_4PI_UT_M_PER_A = 0.1
#: Closest distance (m) at which a dipole's field is evaluated: a sensor cannot be inside the steel.
DIPOLE_CORE_M = 0.05

#: Heading scatter (standard deviation over the room, degrees) of a level compass that de Vries
#: et al. measured at 5 cm and at 100 cm above a motion lab's floor.
FLOOR_HEADING_SD_DEG = {0.05: 29.0, 1.00: 3.0}
#: Decay rate (1/m) of the floor's field with height: with it, the heading scatter of the
#: clinic's floor falls from 5 cm to 100 cm by the factor 29° / 3° that de Vries et al. measured
#: (fitted numerically for the default earth field, 49.3 µT at 60° dip; a test checks it).
FLOOR_DECAY_PER_M = 2.26


@dataclass(frozen=True)
class FloorField:
    """The field of a reinforced floor: harmonics of wavenumber ``decay_per_m`` (1/m) whose
    wave vectors point at ``directions_deg`` (from east, counter-clockwise), each of magnitude
    ``amplitude_uT`` at the floor (z = 0) and phase ``phases_rad``."""

    amplitude_uT: float
    decay_per_m: float
    directions_deg: tuple[float, ...]
    phases_rad: tuple[float, ...]

    def field_uT(self, position_m: np.ndarray) -> np.ndarray:
        """Field (n,3) µT at positions (n,3) m (above the floor: z ≥ 0; lower points are
        evaluated at the floor)."""
        p = np.asarray(position_m, dtype=np.float64)
        k = self.decay_per_m
        envelope = self.amplitude_uT * np.exp(-k * np.maximum(p[..., 2], 0.0))
        field = np.zeros(p.shape)
        for direction_deg, phase in zip(self.directions_deg, self.phases_rad):
            ux, uy = math.cos(math.radians(direction_deg)), math.sin(math.radians(direction_deg))
            theta = k * (ux * p[..., 0] + uy * p[..., 1]) + phase
            # B = -∇Φ for Φ = (A/k) e^{-kz} cos θ: horizontal along the wave vector, vertical in quadrature.
            s, c = np.sin(theta), np.cos(theta)
            field[..., 0] += envelope * ux * s
            field[..., 1] += envelope * uy * s
            field[..., 2] += envelope * c
        return field


@dataclass(frozen=True)
class SteelObject:
    """A steel object as a cluster of magnetic dipoles: ``positions_m`` (k,3) world,
    ``moments_A_m2`` (k,3) world; ``name`` says what it is."""

    name: str
    positions_m: np.ndarray
    moments_A_m2: np.ndarray

    def field_uT(self, position_m: np.ndarray) -> np.ndarray:
        """Field (n,3) µT of all dipoles at positions (n,3) m."""
        p = np.asarray(position_m, dtype=np.float64)
        field = np.zeros(p.shape)
        for centre, moment in zip(self.positions_m, self.moments_A_m2):
            r = p - centre
            distance = np.maximum(np.linalg.norm(r, axis=-1), DIPOLE_CORE_M)[..., None]
            unit = r / distance
            along = (unit * moment).sum(axis=-1, keepdims=True)
            field += MU0_OVER_4PI_UT_M_PER_A * (3.0 * along * unit - moment) / distance**3
        return field


@dataclass(frozen=True)
class Room:
    """A room: its ``floor`` (or None), its ``objects`` of steel, and whether the subject
    walks on a ``treadmill`` belt (walking then keeps the subject in place, the belt carrying
    the stance foot back at the mean walking speed)."""

    name: str
    floor: FloorField | None = None
    objects: tuple[SteelObject, ...] = ()
    treadmill: bool = False

    @property
    def is_clean(self) -> bool:
        return self.floor is None and not self.objects

    def field_uT(self, position_m: np.ndarray) -> np.ndarray:
        """The room's field (n,3) µT at positions (n,3) m, to be added to the earth field."""
        p = np.asarray(position_m, dtype=np.float64)
        field = np.zeros(p.shape)
        if self.floor is not None:
            field += self.floor.field_uT(p)
        for item in self.objects:
            field += item.field_uT(p)
        return field


def _cluster(name: str, corners: tuple[tuple[float, float, float], tuple[float, float, float]],
             counts: tuple[int, int, int], moment_A_m2: tuple[float, float, float]) -> SteelObject:
    """Dipoles on a regular grid spanning the box between two corners, each of the same moment."""
    axes = [np.linspace(lo, hi, n) if n > 1 else np.array([0.5 * (lo + hi)])
            for lo, hi, n in zip(corners[0], corners[1], counts)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    return SteelObject(name, grid, np.tile(np.asarray(moment_A_m2, dtype=np.float64), (grid.shape[0], 1)))


def _join(name: str, parts: list[SteelObject]) -> SteelObject:
    return SteelObject(name, np.concatenate([p.positions_m for p in parts]),
                       np.concatenate([p.moments_A_m2 for p in parts]))


#: The floor of the clinic: three harmonics 60° apart. Their magnitude is that of de Vries et
#: al.'s lab made about 12 % stronger (a level compass scatters by about 32° at 5 cm and 3.4° at
#: 1 m instead of 29° and 3°; floors differ with their construction), so that the foot units,
#: about 9 cm above the floor, see on average at least 20 µT.
CLINIC_FLOOR = FloorField(amplitude_uT=15.8, decay_per_m=FLOOR_DECAY_PER_M,
                          directions_deg=(10.0, 70.0, 130.0), phases_rad=(0.4, 2.1, 4.0))

#: Centre (m, world) of the clinic's bed: its long side runs along the walkway (north), its
#: near edge 0.45 m east of the walkway's line, 3-5 m north of the start.
BED_CENTRE_M = (0.9, 4.0, 0.45)
#: Length (north), width (east) and frame height (m) of the bed.
BED_SIZE_M = (2.0, 0.9, 0.45)


def _bed() -> SteelObject:
    """A steel hospital bed: two long side rails and the cross members of its frame at 0.45 m,
    magnetised mostly along the earth field (north and down) like soft steel, and the electric
    actuator's motor under the frame, near the walkway."""
    cx, cy, cz = BED_CENTRE_M
    length, width, _ = BED_SIZE_M
    x0, x1 = cx - width / 2, cx + width / 2
    y0, y1 = cy - length / 2, cy + length / 2
    induced = (0.0, 2.0, -3.5)
    rails = [_cluster("rail", ((x, y0, cz), (x, y1, cz)), (1, 9, 1), induced) for x in (x0, x1)]
    ends = [_cluster("end", ((x0, y, cz), (x1, y, cz)), (4, 1, 1), induced) for y in (y0, y1)]
    legs = [_cluster("leg", ((x, y, 0.05), (x, y, cz)), (1, 1, 3), (0.0, 1.0, -2.0)) for x in (x0, x1) for y in (y0, y1)]
    motor = SteelObject("motor", np.array([[x0 + 0.15, cy, 0.30]]), np.array([[-6.0, 4.0, -8.0]]))
    return _join("bed", rails + ends + legs + [motor])


#: Half the distance (m) between the treadmill's side rails, where its frame ends behind and in
#: front of a subject standing at the origin facing north, and the depth of the frame under the
#: belt surface (z = 0 on the belt).
TREADMILL_HALF_WIDTH_M = 0.24
TREADMILL_REAR_FRONT_M = (-0.7, 0.9)
TREADMILL_FRAME_DEPTH_M = 0.15


def _treadmill() -> SteelObject:
    """A treadmill under a subject standing at the origin facing north: two steel side rails
    and six cross members of the frame under the deck, the front and rear rollers, and the
    drive motor under the hood at the front."""
    half, depth = TREADMILL_HALF_WIDTH_M, TREADMILL_FRAME_DEPTH_M
    y0, y1 = TREADMILL_REAR_FRONT_M
    rails = [_cluster("rail", ((x, y0, -depth), (x, y1, -depth)), (1, 13, 1), (0.0, 3.75, -8.75)) for x in (-half, half)]
    cross = _cluster("cross member", ((-half, y0, -depth), (half, y1, -depth)), (5, 6, 1), (0.0, 0.0, -2.0))
    rollers = [_cluster("roller", ((-half, y, -0.05), (half, y, -0.05)), (5, 1, 1), (0.0, 1.0, -2.5)) for y in (y0, y1)]
    motor = SteelObject("motor", np.array([[0.0, y1 + 0.25, 0.0]]), np.array([[2.0, -6.0, -8.0]]))
    return _join("treadmill", rails + [cross] + rollers + [motor])


ROOMS: dict[str, Room] = {
    "clean": Room("clean"),
    "clinic": Room("clinic", floor=CLINIC_FLOOR, objects=(_bed(),)),
    "treadmill": Room("treadmill", objects=(_treadmill(),), treadmill=True),
}


def room(name: str) -> Room:
    """The room preset ``name`` (``clean``, ``clinic``, ``treadmill``)."""
    try:
        return ROOMS[name]
    except KeyError:
        raise ValueError(f"unknown room {name!r}; use one of {', '.join(ROOMS)}") from None
