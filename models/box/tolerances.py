"""The exact box-box solver's tolerances and tables, in one place.

Every tolerance of the solver (:mod:`impactnet.models.box.kernels` and its stage modules) is
relative to the *pair scale*: the sum of the two boxes' largest half-extents (metres), so that
a pair answers the same at every size and distance from the origin. The compound oracle's
convex solver (:mod:`impactnet.models.compound`) reuses them, as does the golden comparison
rule (``tests/golden/rule.py``, which writes them out and checks them against this module).
"""
from __future__ import annotations

import numpy as np

from impactnet.models import contacts as ct

# ---------------------------------------------------------------------------------------------
# Stage 2: the separating-axis test and its tie rule (kernel_sat).

#: Relative tolerance (x pair scale, metres) for ties among face axes: rounding of an overlap
#: is a few ulps of the scale, so differences below this are noise, not geometry.
TIE_TOL_REL = 1e-12
#: Angle band (radians) of rule 1: a cross axis closer than this to the least-overlap face's
#: normal is that face's contact seen through a tilt. 1e-2 rad covers the stacking tilts of a
#: crane (a container set down a fraction of a degree out of level; MuJoCo's box-box uses a
#: wider band, |cos| > 0.99, with a 5 % depth bias on top). A genuine edge-on-edge contact
#: (crossed or skewed edges, each box presenting an edge) has its cross axis tens of degrees
#: from the face normals. A cross axis lies in the plane perpendicular to its edge of A, so on
#: uniformly random poses it falls in the band with probability about 1.3 phi (1.3 %); its
#: face answer is then within phi of it and as deep as the region it touches.
FACE_AXIS_ANGLE_TOL = 1e-2
#: cos(FACE_AXIS_ANGLE_TOL) (dimensionless): the band is tested on the cosine of the angle to
#: the face normal.
FACE_AXIS_COS_TOL = float(np.cos(FACE_AXIS_ANGLE_TOL))
#: Depth gain (x pair scale, metres) of rule 2: a cross axis must be shallower than the best
#: face axis by more than this to win. Far above the overlaps' rounding (1e-16 of the scale)
#: and far below any depth a simulator resolves; two features touching within it are a tie.
DEPTH_GAIN_TOL_REL = 1e-9
#: Slack (x pair scale, metres) of rule 3: a closest point this far past an edge's end still
#: counts as inside (a vertex lying on an edge is both answers at once).
EDGE_INSIDE_TOL_REL = 1e-9
#: Relative tolerance (x pair scale, metres) under which two boxes still count as touching: a
#: pair placed exactly in contact computes an overlap of +-few ulps and must not flicker.
CONTACT_TOL_REL = 1e-12
#: Scale-aware parallel-edge test (x pair scale, metres): a cross axis is skipped when the skew
#: of the two edges (sine of their angle) times the longer edge length is below this fraction
#: of the pair's scale, i.e. when the edges' misalignment over their length is rounding noise.
EDGE_SKEW_TOL_REL = 1e-12
#: Overlap (metres) assigned to skipped axes: they neither separate nor win.
SKIPPED_AXIS_OVERLAP = np.inf

# ---------------------------------------------------------------------------------------------
# Stage 3: the face manifold (kernel_face).

#: Relative tolerance (x pair scale, metres) under which two candidate manifold points, or a
#: point and a clip boundary, are the same: equal boxes stacked exactly produce coincident
#: candidates that differ only by rounding.
SNAP_TOL_REL = 1e-12
#: Quad vertices in cyclic order, as signs along the incident face's two in-plane axes p, q
#: (dimensionless); also the reference rectangle's corners as signs along u, w.
QUAD_SIGNS = np.array([[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]])
#: Contact type of a face-axis contact by the incident feature's rank (1 vertex, 2 edge,
#: 3 face), the reference face being A's (FACE_REF_CODES) or B's (FACE_INC_CODES).
FACE_REF_CODES = np.array([0, ct.FACE_VERTEX, ct.FACE_EDGE, ct.FACE_FACE], np.int8)
FACE_INC_CODES = np.array([0, ct.VERTEX_FACE, ct.EDGE_FACE, ct.FACE_FACE], np.int8)
#: Bit weights of the x, y, z signs in a vertex id (box_features' ids).
VERTEX_WEIGHTS = np.array([4, 2, 1], np.int64)
#: Bit weights of the signs in an edge id, by the edge's axis (row) and the axis (column): the
#: two other axes j < l weigh 2 and 1.
EDGE_WEIGHTS = np.array([[0, 2, 1], [2, 0, 1], [2, 1, 0]], np.int64)

# ---------------------------------------------------------------------------------------------
# Stage 4: the centre of pressure (kernel_pressure).

#: Depth floor of the pressure, times the pair's scale (metres): the region is ``d >= -tau``
#: and the pressure ``d + tau``. It turns exactly touching faces, edges and vertices into
#: regions of positive area (no 0/0), is far above rounding (1e-16 of the scale) and far below
#: any depth a simulator resolves, and must exceed :data:`CONTACT_TOL_REL` so that a colliding
#: pair has a non-empty region.
PRESSURE_FLOOR_REL = 1e-9
#: A face contact's depth is the SAT overlap along its normal unless the region's deepest point
#: is shallower than that by more than this (x pair scale, metres): the incident box's deepest
#: vertex then hangs beyond the reference face, and the region's depth is the penetration.
#: Above the rounding of ``(d + tau) - tau`` (1e-16 of the scale), so that where the two agree
#: the depth stays the SAT overlap to the last bit (the region labeller's).
REGION_DEPTH_TOL_REL = 1e-9
