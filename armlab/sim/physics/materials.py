"""The blocks' material and the contact model's settings.

Wood: the kit's blocks are wooden cubes (the lab's notes: large 38 mm, small 25 mm). The density (also the
simulated arm's, for a held block's weight: ArmRealism.block_density_kg_m3) is 600 kg/m^3, within the 500-750 kg/m^3
of pine to beech, so a large block weighs 32.9 g and a small one 9.4 g; an assumed value, not weighed on the bench.
Friction: dry wood on wood slides at 0.25-0.5 in engineering tables; 0.4 is used for every pair (MuJoCo takes the
larger of two geoms' coefficients). The board (printed paper on wood) is taken as the same.

Contact settings (MuJoCo option and geom attributes), chosen by measurement (2026-12-06, MuJoCo 3.17.0): towers of
large blocks placed exactly in contact, each level shifted s mm further out (+x), run for 3 s of physics; the figure
is the largest horizontal drift of any block (a fall shows as hundreds of mm). Statics has (10 blocks, s = 0 and
3 mm), (14, 0) and (7, 5) stand (centre of mass of everything above within 17.5 mm of the 19 mm half edge at most),
(5, 9) and (10, 5) fall.

    cone       impratio noslip solref   (10,0)  (10,3)  (14,0)  (7,5)      per step (10 blocks, loaded machine)
    pyramidal  1        0      0.004    0.00    1.22    0.00    336 fell   240 us
    pyramidal  1        0      0.01     0.00    1.10    0.00    0.87       250 us
    pyramidal  1        5      0.01     0.04    0.69    0.03    0.26       1100 us
    pyramidal  10       0      0.004    0.00    1.19    0.00    367 fell   360 us
    pyramidal  10       0      0.01     0.00    0.07    0.00    0.04       300 us   <- chosen
    pyramidal  10       5      0.01     0.00    0.06    0.01    0.03       1100 us
    elliptic   1 or 10  0 or 5 0.004/0.01  (10, 3) or (7, 5) fell in every combination
and with the chosen ones, (5, 9) and (10, 5) fall. solref 0.02 (MuJoCo's default) let (10, 3) fall at a 4 ms step
and drift 0.33 mm at 2 ms; condim 3 drifts 0.11 mm where condim 4 drifts 0.07. Hence:
    timestep 2 ms, solref (0.01, 1): a contact stiff enough that a stack does not sway (0.004 s, stiffer, rings and
        tips marginal towers), critically damped, five steps per time constant.
    cone pyramidal, impratio 10: the frictional constraints ten times stiffer than the normal ones, so a resting
        stack does not creep (soft contacts otherwise let it slide slowly under a sideways load); the elliptic cone
        lost marginal towers that statics has standing.
    noslip off: it bought 0.01-0.03 mm for four times the step time.
    condim 3: sliding friction only. Box-on-box contacts come as several points over the face, whose sliding
        friction already resists a twist; condim 4's torsional friction (0.002 m) fed a sway that never died out: a
        tower of ten, its upper levels let go tilted in to the sky (seed 1), swung +-7 mm at its top at up to 125 mm/s
        and still moved after 15 s of physics. Measured 2026-12-07 on the same towers (3 s, largest drift):
                    (10,0)  (10,3)  (14,0)  (7,5)  (5,9)     (10,5)     that tower of ten     per step (10 blocks)
        condim 4    0.00    0.06    0.00    0.04   183 fell  476 fell   moving after 15 s     66 us
        condim 3    0.00    0.10    0.00    0.06   181 fell  420 fell   at rest after 1.17 s  50 us
        (a lightly loaded machine); torsional coefficient 0.0005 / 0.001 / 0.005 m rested after 1.7 / 6.0 / > 15 s.
        The cost: a small block riding on a pushed stack turns 2.5 deg over a 60 mm push (condim 4: under 2).
    solimp (0.95, 0.99, 0.001): the impedance close to 1 at a penetration of 1 mm or less.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Wood", "WOOD", "ContactSettings", "CONTACT"]


@dataclass(frozen=True)
class Wood:
    """The blocks' wood: density (kg/m^3) and friction coefficients (sliding, torsional m, rolling m)."""

    density_kg_m3: float = 600.0
    sliding: float = 0.4
    torsional_m: float = 0.002
    rolling_m: float = 0.0


WOOD = Wood()


@dataclass(frozen=True)
class ContactSettings:
    """MuJoCo's solver and contact settings (see the module notes for why each value).

    timestep_s: physics step (s); solref: (time constant s, damping ratio); solimp: (d0, dwidth, width m);
    cone: "elliptic" or "pyramidal"; impratio: frictional-to-normal impedance ratio; condim: contact dimensionality;
    noslip_iterations: MuJoCo's post-solver sliding correction (0 = off); iterations: the solver's iterations.
    """

    timestep_s: float = 0.002
    solref: tuple[float, float] = (0.01, 1.0)
    solimp: tuple[float, float, float] = (0.95, 0.99, 0.001)
    cone: str = "pyramidal"
    impratio: float = 10.0
    condim: int = 3
    noslip_iterations: int = 0
    iterations: int = 50


CONTACT = ContactSettings()
