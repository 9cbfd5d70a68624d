"""What the simulated suit gives for an interval of time: the samples its units deliver,
the ground truth at every sample, and the markers of the activities that start in it.

Frames: world ENU (z up), segment frames ISB, sensor frames the device axes; quaternions
scalar-first Hamilton, ``q_A_from_B``. Units: s, m, rad/s, µT, degrees for joint angles.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mimucap.core.samples import SensorSamples, concatenate_samples


@dataclass
class SuitTruth:
    """Ground truth at every simulated sample (dropped or not), ``t_s`` (T,).

    ``q_world_from_segment`` segment → (T,4); ``joint_angles_deg`` column
    (``<joint>_<flexion|adduction|rotation>_deg``) → (T,); ``root_position_m`` (T,3) pelvis
    root; per sensor id: ``q_world_from_sensor`` (T,4), ``position_m`` (T,3) world,
    ``gyr_bias_rad_s`` (T,3), ``field_world_uT`` (T,3); ``mag_axis_turned`` (T,) bundle axis
    0/1/2 turned during a hand-held magnetometer calibration, −1 otherwise; ``held`` sensor id →
    (T,) weight of being held in the hands (1) rather than worn (0); ``foot_contact`` (T,2)
    whether the left and right foot are on the ground (1) or in the air (0), blended like the
    poses (gait-event truth: a contact begins where it rises through 0.5).
    """

    t_s: np.ndarray
    q_world_from_segment: dict[str, np.ndarray]
    joint_angles_deg: dict[str, np.ndarray]
    root_position_m: np.ndarray
    q_world_from_sensor: dict[str, np.ndarray]
    position_m: dict[str, np.ndarray]
    gyr_bias_rad_s: dict[str, np.ndarray]
    field_world_uT: dict[str, np.ndarray]
    mag_axis_turned: np.ndarray
    held: dict[str, np.ndarray]
    foot_contact: np.ndarray

    @staticmethod
    def concatenate(parts: list[SuitTruth]) -> SuitTruth:
        def cat_dict(name: str) -> dict[str, np.ndarray]:
            return {k: np.concatenate([getattr(p, name)[k] for p in parts]) for k in getattr(parts[0], name)}

        return SuitTruth(
            t_s=np.concatenate([p.t_s for p in parts]),
            q_world_from_segment=cat_dict("q_world_from_segment"), joint_angles_deg=cat_dict("joint_angles_deg"),
            root_position_m=np.concatenate([p.root_position_m for p in parts]),
            q_world_from_sensor=cat_dict("q_world_from_sensor"), position_m=cat_dict("position_m"),
            gyr_bias_rad_s=cat_dict("gyr_bias_rad_s"), field_world_uT=cat_dict("field_world_uT"),
            mag_axis_turned=np.concatenate([p.mag_axis_turned for p in parts]), held=cat_dict("held"),
            foot_contact=np.concatenate([p.foot_contact for p in parts]),
        )


@dataclass
class SuitBlock:
    """One interval of simulation: ``samples`` per sensor id, ``truth``, and ``markers``
    ``(t_s, label)`` for activities starting in the interval (labels of :mod:`mimucap.core.phases`:
    "magnetometer turns", "N-pose", "T-pose", "walk", ...).

    A unit's :class:`~mimucap.core.samples.SensorSamples` are those it delivered (dropped ones
    removed): ``t_s`` the true time, ``seq`` the sample numbers, ``acc``, ``gyr``, ``mag_uT``,
    ``q_world_from_sensor`` when the units fuse on board (else None), ``device_time_s`` the
    unit's clock, ``segment`` the segment it drives
    (:func:`~mimucap.core.simulate.config.default_assignment`; ``None`` for a second unit on a
    segment, whose placement is in the simulator's ``mounting``)."""

    samples: dict[str, SensorSamples]
    truth: SuitTruth
    markers: list[tuple[float, str]]

    @staticmethod
    def concatenate(blocks: list[SuitBlock]) -> SuitBlock:
        """Join consecutive blocks into one."""
        if not blocks:
            raise ValueError("nothing to concatenate")
        return SuitBlock(
            samples={k: concatenate_samples([b.samples[k] for b in blocks]) for k in blocks[0].samples},
            truth=SuitTruth.concatenate([b.truth for b in blocks]),
            markers=[m for b in blocks for m in b.markers],
        )



def slice_block(block: SuitBlock, block_start: int, k0: int, k1: int, dt: float) -> SuitBlock:
    """Samples ``k0 .. k1-1`` of ``block``, whose first truth row is sample ``block_start``."""
    a, b = k0 - block_start, k1 - block_start
    samples = {}
    for sid, s in block.samples.items():
        i0, i1 = np.searchsorted(s.seq, [k0, k1])
        samples[sid] = s.rows(slice(i0, i1))
    tr = block.truth
    cut = lambda d: {k: v[a:b] for k, v in d.items()}  # noqa: E731
    truth = SuitTruth(
        t_s=tr.t_s[a:b], q_world_from_segment=cut(tr.q_world_from_segment), joint_angles_deg=cut(tr.joint_angles_deg),
        root_position_m=tr.root_position_m[a:b], q_world_from_sensor=cut(tr.q_world_from_sensor),
        position_m=cut(tr.position_m), gyr_bias_rad_s=cut(tr.gyr_bias_rad_s), field_world_uT=cut(tr.field_world_uT),
        mag_axis_turned=tr.mag_axis_turned[a:b], held=cut(tr.held), foot_contact=tr.foot_contact[a:b],
    )
    markers = [(t, label) for t, label in block.markers if k0 * dt <= t < k1 * dt]
    return SuitBlock(samples=samples, truth=truth, markers=markers)
