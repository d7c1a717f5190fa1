"""The fill-shape cases of commands.json: valid shapes (the photo's, exotic numbers, zones) and every way a
fill field is refused."""

from __future__ import annotations

from agent.protocol.command import MAX_RINGS, MAX_VERTICES

from .common import SECRET, body, canonical, one_class, relaid, reserialised, sign, sign_raw
from .shapes import ZONE, fill, photo_command, polygon, raw_fill, square


def fill_command_cases() -> list:
    photo = photo_command()
    assert photo.fill is not None and len(photo.fill.rings) > 1
    triangles = [[[3.0 * k, 0.0], [3.0 * k + 1.0, 0.0], [3.0 * k, 1.0]] for k in range(MAX_RINGS + 1)]
    exact = body(fill=fill(rings=[[[0, 0], [10, 0], [10.5, 12.3456], [-0.0, 1e-05], [-1000000, 1e6]]], alpha=80, s=0))
    return [
        ("valid_fill_photo", photo.encode(SECRET)),
        ("fill_photo_envelope_relaid", relaid(photo.body())),
        ("valid_fill_ints_and_exotic_floats", sign(exact)),
        ("valid_fill_ints_and_exotic_floats_indented", sign_raw(reserialised(exact, indent=1))),
        (
            "valid_fill_float_other_spellings",  # the same values as valid_fill_ints_and_exotic_floats
            sign_raw(reserialised(exact, indent=1).replace(b"12.3456", b"1234.56e-2").replace(b"1e-05", b"0.00001000")),
        ),
        ("valid_fill_hole", sign(body(fill=fill(rings=[square(0.0, 0.0, 10.0), square(4.0, 4.0, 2.0)])))),
        (
            "valid_fill_rings_touch_at_a_vertex",
            sign(body(fill=fill(rings=[square(0.0, 0.0, 1.0), square(1.0, 1.0, 1.0)]))),
        ),
        (
            "valid_fill_collinear_overlap",  # a spike back along an edge, as pixel contours have
            sign(body(fill=fill(rings=[[[0.0, 0.0], [4.0, 0.0], [2.0, 0.0], [2.0, 3.0]]]))),
        ),
        (
            "valid_fill_vertex_on_an_edge",
            sign(body(fill=fill(rings=[[[0.0, 0.0], [4.0, 0.0], [4.0, 4.0]], [[2.0, 0.0], [3.0, -1.0], [1.0, -1.0]]]))),
        ),
        (
            "valid_fill_duplicate_vertex",
            sign(body(fill=fill(rings=[[[0.0, 0.0], [0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]]))),
        ),
        ("valid_fill_rings_32", sign(body(fill=fill(rings=triangles[:MAX_RINGS])))),
        ("valid_fill_vertices_512", sign(body(fill=fill(rings=[polygon(MAX_VERTICES)])))),
        (
            "valid_fill_bounds",
            sign(body(fill=fill(rings=[[[-1e6, -1e6], [1e6, -1e6], [0, 1000000]]], alpha=10000, s=1e6))),
        ),
        (
            "valid_fill_small_ints_alpha_s_zero",
            sign(body(fill=fill(rings=[[[-1, 0], [1, 0], [0, 1]]], alpha=0, s=0.0))),
        ),
        ("valid_fill_zones", sign(body(fill=fill(zones=[ZONE, dict(ZONE, x=-4, ux=1, uy=0, beta=5, mu=0)])))),
        ("valid_fill_zones_empty", sign(body(fill=fill(zones=[])))),
        ("valid_fill_zones_16", sign(body(fill=fill(zones=[dict(ZONE, x=float(k)) for k in range(16)])))),
        ("fill_zones_17", sign(body(fill=fill(zones=[dict(ZONE, x=float(k)) for k in range(17)])))),
        ("fill_zones_not_list", sign(body(fill=fill(zones=ZONE)))),
        ("fill_zone_not_object", sign(body(fill=fill(zones=[[1.0, 2.0, 0.6, 0.8, 3.0, 1.5, 20.0, 1.0]])))),
        ("fill_zone_unknown_key", sign(body(fill=fill(zones=[dict(ZONE, r=1.0)])))),
        ("fill_zone_missing_mu", sign(body(fill=fill(zones=[{k: v for k, v in ZONE.items() if k != "mu"}])))),
        ("fill_zone_axis_not_unit", sign(body(fill=fill(zones=[dict(ZONE, ux=0.6, uy=0.81)])))),
        ("fill_zone_axis_beyond_1", sign(body(fill=fill(zones=[dict(ZONE, ux=1.5, uy=0.0)])))),
        ("fill_zone_a_zero", sign(body(fill=fill(zones=[dict(ZONE, a=0.0)])))),
        ("fill_zone_b_negative", sign(body(fill=fill(zones=[dict(ZONE, b=-1.0)])))),
        ("fill_zone_beta_beyond_1e4", sign(body(fill=fill(zones=[dict(ZONE, beta=10001.0)])))),
        ("fill_zone_mu_bool", sign(body(fill=fill(zones=[dict(ZONE, mu=True)])))),
        ("fill_zone_x_nan", sign_raw(canonical(body(fill=fill(zones=[dict(ZONE, x="@@")]))).replace(b'"@@"', b"NaN"))),
        ("fill_crossing_rings", sign(body(fill=fill(rings=[square(0.0, 0.0, 2.0), square(1.0, 1.0, 2.0)])))),
        ("fill_bow_tie", sign(body(fill=fill(rings=[[[0.0, 0.0], [1.0, 1.0], [1.0, 0.0], [0.0, 1.0]]])))),
        (
            "fill_ring_crosses_itself_far_apart",
            sign(body(fill=fill(rings=[[[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [5.0, -5.0], [0.0, 10.0]]]))),
        ),
        ("fill_vertices_513", sign(body(fill=fill(rings=[polygon(MAX_VERTICES + 1)])))),
        (
            "fill_vertices_513_over_two_rings",
            sign(body(fill=fill(rings=[polygon(300, radius=10.0), polygon(MAX_VERTICES + 1 - 300, radius=5.0)]))),
        ),
        ("fill_rings_33", sign(body(fill=fill(rings=triangles)))),
        ("fill_rings_empty", sign(body(fill=fill(rings=[])))),
        ("fill_rings_not_list", sign(body(fill=fill(rings={"a": square(0.0, 0.0, 1.0)})))),
        ("fill_rings_missing", sign(body(fill={"alpha": 80.0, "s": 0.2}))),
        ("fill_ring_2_vertices", sign(body(fill=fill(rings=[square(0.0, 0.0, 5.0), [[0.0, 0.0], [1.0, 1.0]]])))),
        ("fill_ring_not_list", sign(body(fill=fill(rings=[{"x": [0.0, 1.0, 2.0]}])))),
        ("fill_vertex_3_numbers", sign(body(fill=fill(rings=[[[0.0, 0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]])))),
        ("fill_vertex_1_number", sign(body(fill=fill(rings=[[[0.0, 0.0], [1.0], [0.0, 1.0]]])))),
        ("fill_vertex_object", sign(body(fill=fill(rings=[[[0.0, 0.0], {"x": 1.0, "y": 0.0}, [0.0, 1.0]]])))),
        ("fill_vertex_number", sign(body(fill=fill(rings=[[[0.0, 0.0], 1.0, [0.0, 1.0]]])))),
        ("fill_vertex_bool", sign(body(fill=fill(rings=[[[True, 0.0], [1.0, 0.0], [0.0, 1.0]]])))),
        ("fill_vertex_string", sign(body(fill=fill(rings=[[["0", 0.0], [1.0, 0.0], [0.0, 1.0]]])))),
        ("fill_vertex_null", sign(body(fill=fill(rings=[[[0.0, None], [1.0, 0.0], [0.0, 1.0]]])))),
        ("fill_vertex_beyond_1e6", sign(body(fill=fill(rings=[[[0.0, 0.0], [1000000.0000000001, 0.0], [0.0, 1.0]]])))),
        ("fill_vertex_int_beyond_1e6", sign(body(fill=fill(rings=[[[0, 0], [1, 0], [0, -1000001]]])))),
        ("fill_vertex_int_2_1023", sign(body(fill=fill(rings=[[[0, 0], [2**1023, 0], [0, 1]]])))),
        ("fill_vertex_int_2_1024", sign(body(fill=fill(rings=[[[0, 0], [2**1024, 0], [0, 1]]])))),
        ("fill_vertex_int_minus_10_400", sign(body(fill=fill(rings=[[[0, 0], [1, 0], [0, -(10**400)]]])))),
        ("fill_vertex_nan", raw_fill(b"NaN")),
        ("fill_vertex_infinity", raw_fill(b"-Infinity")),
        ("fill_vertex_1e400", raw_fill(b"1e400")),
        ("fill_vertex_int_4301_digits", raw_fill(b"9" * 4301)),
        ("fill_unknown_key", sign(body(fill=fill(r=1.0)))),
        ("fill_not_object", sign(body(fill=[square(0.0, 0.0, 1.0)]))),
        ("fill_null", sign(body(fill=None))),
        ("fill_alpha_missing", sign(body(fill={"rings": [square(0.0, 0.0, 1.0)], "s": 0.2}))),
        ("fill_alpha_beyond_1e4", sign(body(fill=fill(alpha=10000.000000000002)))),
        ("fill_alpha_bool", sign(body(fill=fill(alpha=True)))),
        ("fill_alpha_int_2_1024", sign(body(fill=fill(alpha=2**1024)))),
        ("fill_s_negative", sign(body(fill=fill(s=-1e-300)))),
        ("fill_s_missing", sign(body(fill={"rings": [square(0.0, 0.0, 1.0)], "alpha": 80.0}))),
        ("beta_int_2_1024", sign(body(beta=2**1024))),  # _num refuses an int float() cannot hold
        ("share_int_minus_2_1100", sign(body(classes=[one_class(share=-(2**1100))]))),
    ]
