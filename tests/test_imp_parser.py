"""Tests of the IMP language reader: lexer, parser, VALUE expressions.

Every statement form of shared/reference/imp-language.md is parsed from a tiny
inline deck; the lexer edge cases and every kind of input error are checked;
a whole four-bar deck is read end to end.
"""

from __future__ import annotations

import math
import os
import random
from pathlib import Path

import pytest

from openimp.errors import InputError
from openimp.imp import (
    DATA_KEYWORDS,
    JOINT_DOF,
    LEADING_KEYWORDS,
    SimulationStop,
    Statement,
    load_table,
    parse,
    parse_expression,
    parse_file,
    parse_statement,
    parse_text,
    split_statements,
    tokenize,
)

DECKS = Path(__file__).parent / "decks"


def one(text: str, **kw) -> Statement:
    """The single statement of ``text``."""
    stmts = parse_text(text, "deck.imp", **kw)
    assert len(stmts) == 1, stmts
    return stmts[0]


def err(text: str, **kw) -> InputError:
    """The InputError raised by parsing ``text``."""
    with pytest.raises(InputError) as info:
        parse_text(text, "deck.imp", **kw)
    return info.value


# --------------------------------------------------------------------------- lexer


class TestLexer:
    def test_text_past_column_72_is_ignored_with_a_warning(self):
        line = "DATA RACK (R) = 1.5".ljust(72) + "99999"
        s = one(line)
        assert s.numbers == [1.5]
        assert any("column 72" in w and "99999" in w for w in s.warnings)

    def test_text_cut_from_a_remark_does_not_warn(self):
        s = one("DATA RACK (R) = 1.5 $$ a long remark".ljust(72) + "running past column 72")
        assert s.numbers == [1.5] and not s.warnings

    def test_column_limit_can_be_lifted(self):
        line = "POINT (L) = A".ljust(72) + ", B"
        assert one(line).fields["points"] == ["A"]
        assert one(line, columns=None).fields["points"] == ["A", "B"]

    def test_dollar_sign_continues_and_starts_a_remark(self):
        s = one("DATA ZPIN (A) = 1,2,$ first point\n3; 4,5,6; 7,8,9\n")
        assert s.numbers == [1, 2, 3, 4, 5, 6, 7, 8, 9]
        assert s.remarks == ["first point"]
        assert (s.line, s.end_line) == (1, 2)
        assert s.text == "DATA ZPIN (A) = 1,2,$ first point\n3; 4,5,6; 7,8,9"

    def test_dollar_may_split_a_word_or_a_number(self):
        s = one("ZPIN (BA$\nSE, L1) = J\n")
        assert s.fields["link1"] == "BASE"
        assert one("DATA RACK (R) = 12$\n34").fields["radius"] == 1234.0

    def test_many_continuation_lines(self):
        s = one("POINT (L) = $\nA, $\nB, $\n  $ just a remark\nC\n")
        assert s.fields["points"] == ["A", "B", "C"]
        assert s.end_line == 5

    def test_double_dollar_ends_the_statement(self):
        s = one("EXECUTE $$ HOLD is only a remark here")
        assert s.keyword == "EXECUTE"
        assert s.remarks == ["HOLD is only a remark here"]

    def test_blank_and_remark_lines_give_no_statement_and_keep_line_numbers(self):
        stmts = parse_text("\n$$ a remark\n   \nCLEAR\n\n  $$ another\nEXECUTE\n")
        assert [(s.keyword, s.line) for s in stmts] == [("CLEAR", 4), ("EXECUTE", 7)]

    def test_implied_zero_between_separators_warns(self):
        s = one("DATA CONTACT (C) = 3.14159, 2.25, , 1, 3.5")
        assert s.numbers == [3.14159, 2.25, 0.0, 1.0, 3.5]
        assert any("implied" in w for w in s.warnings)

    def test_sign_in_front_of_a_digit_is_not_a_separator(self):
        s = one("DATA CONTACT (C) = 3.14159,-2.25, , 1,+3.5")
        assert s.numbers == [3.14159, -2.25, 0.0, 1.0, 3.5]
        s = one("SLIDE (Y)=-20")
        assert s.fields["distance"] == -20.0
        assert not s.warnings

    def test_number_forms(self):
        s = one("DATA VIEW = -.232, -.5, 1.E-3; +31.964276e+4, 31964276E-2, 3.1964276E5")
        assert s.numbers == pytest.approx([-0.232, -0.5, 1e-3, 319642.76, 319642.76, 319642.76])

    def test_junk_after_a_number_is_skipped_with_a_warning(self):
        s = one("DATA GRAVITY = 3.8.0, 30.0E, 1")
        assert s.numbers == [3.8, 30.0, 1.0]
        assert sum("ignored" in w for w in s.warnings) == 2

    def test_keywords_are_case_insensitive_and_names_keep_their_case(self):
        s = one("zpin (base, Crnk) = a")
        assert (s.kind, s.keyword, s.names) == ("DEFINE", "ZPIN", ["base", "Crnk", "a"])
        assert one("exec hold").keyword == "EXECUTE HOLD"

    def test_only_four_characters_are_significant(self):
        s = one("POINT (LINK1) = POINT12, POINT35")
        assert s.fields == {"link": "LINK", "points": ["POIN", "POIN"]}
        s = one("POINT (LINK1) = POINT12, POINT35", significant=None)
        assert s.fields["points"] == ["POINT12", "POINT35"]
        assert one("PRINT POSITIONS (JT5)").keyword == "PRINT POSITION"

    def test_tokens_keep_file_line_and_column(self):
        src = next(split_statements("\n  DATA ZPIN (A) = 1,$\n -2.5", "f.imp"))
        toks = tokenize(src)
        assert (src.file, src.line) == ("f.imp", 2)
        assert (toks[0].text, toks[0].line, toks[0].col) == ("DATA", 2, 3)
        assert (toks[-1].text, toks[-1].line, toks[-1].col) == ("2.5", 3, 3)
        assert toks[-2].text == "-"

    def test_colon_is_a_separator(self):
        s = one("PRINT: POSITION(J1, J2)")
        assert s.fields["names"] == ["J1", "J2"]

    def test_closing_parenthesis_is_ignored_outside_value(self):
        assert one("ZPIN (A, B)) = C").fields["joint"] == "C"

    def test_more_than_35_words_is_only_a_warning(self):
        names = ", $\n".join(", ".join(f"P{i}" for i in range(k, k + 10)) for k in (0, 10, 20, 30))
        s = one(f"POINT (L) = {names}")
        assert len(s.fields["points"]) == 40
        assert any("35 words" in w for w in s.warnings)
        assert any("33 names" in w for w in s.warnings)

    def test_tabs_and_crlf(self):
        s = one("ZPIN\t(A,B)\t= C\r\n")
        assert s.fields["joint"] == "C"


# --------------------------------------------------------------------------- definitions


class TestDefinitions:
    @pytest.mark.parametrize("jtype", sorted(JOINT_DOF))
    def test_every_joint_type(self, jtype):
        s = one(f"{jtype} (L1, L2) = JT")
        assert (s.kind, s.keyword) == ("DEFINE", jtype)
        assert s.names == ["L1", "L2", "JT"]
        assert s.fields == {"type": jtype, "link1": "L1", "link2": "L2", "joint": "JT",
                            "dof": JOINT_DOF[jtype]}

    def test_joint_without_punctuation(self):
        assert one("ZPIN BASE LKBD = D").fields["link2"] == "LKBD"

    def test_joint_dof_table(self):
        assert JOINT_DOF["RIGID"] == 0 and JOINT_DOF["OPEN"] == 6
        assert sum(JOINT_DOF.values()) == 0 + 12 * 1 + 4 * 2 + 3 * 3 + 6

    def test_link_and_ground(self):
        assert one("LINK = CRANK").fields == {"link": "CRAN"}
        s = one("GROUND = FRAME")
        assert (s.kind, s.keyword, s.fields) == ("DEFINE", "GROUND", {"link": "FRAM"})

    def test_solid_read_keeps_the_raw_file_name(self):
        s = one("SOLID READ (AD) = parts/arm-2.geo")
        assert (s.kind, s.keyword) == ("DEFINE", "SOLID READ")
        assert s.fields == {"solid": "AD", "filename": "parts/arm-2.geo"}

    def test_shape(self):
        s = one("SHAPE (SHAFT) = ROD, HUB")
        assert s.fields == {"link": "SHAF", "solids": ["ROD", "HUB"]}

    def test_contact(self):
        s = one("CONTACT (BALL, WALL) = HIT")
        assert s.fields == {"solid1": "BALL", "solid2": "WALL", "contact": "HIT"}

    def test_impact(self):
        s = one("IMPACT = 1, 2, 3")
        assert s.fields == {"tangent": 1, "moment": 2, "torsion": 3}

    def test_point(self):
        s = one("POINT (CPLR) = P1, P2, P3, P1")
        assert s.fields == {"link": "CPLR", "points": ["P1", "P2", "P3", "P1"]}
        assert one("POINT LKGH = F0").fields["points"] == ["F0"]

    @pytest.mark.parametrize("kw", ["SPRING", "DAMPER"])
    def test_spring_and_damper(self, kw):
        s = one(f"{kw} (P1, P2) = S1")
        assert (s.keyword, s.fields) == (kw, {"point1": "P1", "point2": "P2", "name": "S1"})

    def test_force(self):
        s = one("FORCE (PA / PB, PC) = F1")
        assert s.fields == {"point": "PA", "point_a": "PB", "point_b": "PC", "name": "F1"}
        assert one("FORCE F0 F1 F2 = P").fields["name"] == "P"

    def test_torque(self):
        s = one("TORQUE (CRNK / PB, PC) = T1")
        assert s.fields == {"link": "CRNK", "point_a": "PB", "point_b": "PC", "name": "T1"}

    def test_value(self):
        s = one("VALUE (DRIVE) = 2.5*SIN(6.2832*T)")
        assert (s.kind, s.keyword, s.names) == ("VALUE", "VALUE", ["DRIV"])
        expr = s.fields["expression"]
        assert s.fields["name"] == "DRIV" and expr.name == "DRIV"
        assert s.fields["source"] == "2.5*SIN(6.2832*T)"
        assert expr.evaluate(resolve=lambda k, n, c: 0.25) == pytest.approx(
            2.5 * math.sin(6.2832 * 0.25))

    def test_value_named_like_a_function_warns(self):
        assert any("function" in w for w in one("VALUE (TIMER) = 1").warnings)


# --------------------------------------------------------------------------- DATA


class TestData:
    def test_data_link_joint_form(self):
        s = one("DATA LINK (LCA, LBAL) = 1,2,3; 4,5,6; 7,8,9")
        assert (s.kind, s.keyword) == ("DATA", "DATA LINK")
        assert s.fields["link"] == "LCA" and s.fields["joint"] == "LBAL"
        assert s.fields["frame"] == "JOINT"
        assert s.fields["points"] == [(1, 2, 3), (4, 5, 6), (7, 8, 9)]
        assert s.fields["filled"] == [False, False, False]
        assert not s.warnings

    def test_data_link_link_form(self):
        s = one("DATA LINK(LCA/LINK)= 0,0,0; 0,0,1; 1,0,0")
        assert (s.fields["frame"], s.fields["joint"]) == ("LINK", None)

    @pytest.mark.parametrize("jtype", ["RIGID", "XPIN", "YPIN", "ZPIN", "PRISM", "CYLINDER",
                                       "UJOINT"])
    def test_three_point_placements(self, jtype):
        s = one(f"DATA {jtype} (J) = 0,0,0; 1,0,0; 0,1,0")
        assert s.keyword == f"DATA {jtype}"
        assert s.fields["joint"] == "J"
        assert s.fields["points"] == [(0, 0, 0), (1, 0, 0), (0, 1, 0)]

    def test_revolute_has_four_points(self):
        s = one("DATA REVOLUTE (J) = 0,0,0; 0,0,1; 1,0,0; 0,1,0")
        assert len(s.fields["points"]) == 4

    @pytest.mark.parametrize("jtype", ["XSLIDE", "YSLIDE", "ZSLIDE", "SPHERE"])
    def test_one_point_placements(self, jtype):
        s = one(f"DATA {jtype} (J) = 1, 2, 3")
        assert s.fields["points"] == [(1, 2, 3)]

    def test_placement_zero_fill_warns_as_imp_did(self):
        s = one("DATA ZPIN D = -2.5,4,0")
        assert s.fields["points"] == [(-2.5, 4, 0), (0, 0, 0), (0, 0, 0)]
        assert s.fields["filled"] == [False, True, True]
        assert "Warning: 6 zeroes are added to complete statement." in s.warnings

    def test_placement_accepts_point_names(self):
        s = one("DATA ZPIN (D) = P1; 10,4,0; P3")
        assert s.fields["points"] == ["P1", (10, 4, 0), "P3"]
        assert s.names == ["D", "P1", "P3"]

    def test_gear(self):
        s = one("DATA GEAR (G) = 2.625, 6.25")
        assert s.fields == {"joint": "G", "ratio": 2.625, "distance": 6.25}
        s = one("DATA GEAR (G) = -2.625")
        assert s.fields["distance"] is None and not s.warnings

    def test_bevel_rack_screw(self):
        assert one("DATA BEVEL (B) = 2.625, 2.0").fields == {"joint": "B", "ratio": 2.625,
                                                               "radius": 2.0}
        assert one("DATA RACK (R) = 1.5").fields == {"joint": "R", "radius": 1.5}
        assert one("DATA SCREW (S) = -0.25").fields == {"joint": "S", "lead": -0.25}

    @pytest.mark.parametrize("kw", ["CAM", "SLOT"])
    def test_cam_and_slot(self, kw):
        s = one(f"DATA {kw} (J) = PROFILE")
        assert s.fields == {"joint": "J", "value": "PROF"}

    def test_data_point_forms(self):
        s = one("DATA POINT (P1, J1) = 1, 2, 3")
        assert s.fields == {"point": "P1", "frame": "JOINT", "joint": "J1", "coords": (1, 2, 3)}
        s = one("DATA POINT (P1, LINK) = 1, 2, 3")
        assert (s.fields["frame"], s.fields["joint"]) == ("LINK", None)
        s = one("DATA POINT(P311/ABSO)= 25.5, 18.4, -17.6")
        assert s.fields["frame"] == "ABS" and s.fields["coords"] == (25.5, 18.4, -17.6)
        assert one("DATA POINT (P1, ABS) = P2").fields["coords"] == "P2"

    def test_data_point_name_only_in_abs_form(self):
        e = err("DATA POINT (P1, LINK) = P2")
        assert "x,y,z" in str(e)

    def test_gravity_and_density(self):
        assert one("DATA GRAVITY = 0,-386.1,0").fields == {"vector": (0, -386.1, 0)}
        assert one("DATA DENSITY (ROD) = 0.286").fields == {"solid": "ROD", "density": 0.286}

    def test_mass(self):
        s = one("DATA MASS (CRNK, A) = 0.5; 3.25,0.0,0.0")
        assert s.fields == {"link": "CRNK", "frame": "JOINT", "joint": "A", "mass": 0.5,
                            "center": (3.25, 0, 0)}
        assert one("DATA MASS (CRNK, LINK) = 2").fields["frame"] == "LINK"

    def test_inertia_zero_fill(self):
        s = one("DATA INERTIA (CRNK, A) = 1, 2, 3")
        assert s.fields["inertia"] == (1, 2, 3, 0, 0, 0)
        assert "Warning: 3 zeroes are added to complete statement." in s.warnings

    def test_spring_pairs_with_values_and_none(self):
        s = one("DATA SPRING (J) = NONE, NONE; 1200,2.5")
        assert s.fields == {"name": "J", "pairs": [(None, None), (1200, 2.5)]}
        s = one("DATA SPRING (S) = K, -45")
        assert s.fields["pairs"] == [("K", -45.0)]
        assert one("DATA SPRING (S) = 100, NONE").fields["pairs"] == [(None, None)]

    def test_damper_force_torque(self):
        assert one("DATA DAMPER (J) = 0.15, NONE").fields == {"name": "J",
                                                              "coefficients": [0.15, None]}
        assert one("DATA DAMPER (D) = C").fields["coefficients"] == ["C"]
        assert one("DATA FORCE (J) = NONE, 15.2").fields == {"name": "J",
                                                             "loads": [None, 15.2]}
        s = one("DATA TORQUE (T) = F")
        assert (s.keyword, s.fields["loads"]) == ("DATA TORQUE", ["F"])

    def test_contact_data(self):
        s = one("DATA CONTACT (HIT) = 0.9, -1.0, 0.0, -1.0, 0.25")
        assert s.fields == {"contact": "HIT", "en": 0.9, "et": -1.0, "eb": 0.0, "er": -1.0,
                            "mu": 0.25}

    def test_position(self):
        s = one("DATA POSITION (JT1) = -90, 15, 24")
        assert s.fields == {"joint": "JT1", "start": -90, "increment": 15, "nsteps": 24}
        s = one("DATA POSITION (J) = 1.75")
        assert (s.fields["increment"], s.fields["nsteps"]) == (0, 0)
        assert not s.warnings
        assert one("DATA POSITION (J) = 5, 0, 10").fields["nsteps"] == 0

    def test_velocity_and_accel(self):
        assert one("DATA VELOCITY (A) = -188.5").fields == {"joint": "A", "velocity": -188.5}
        s = one("DATA ACCELERATION (A) = 3")
        assert (s.keyword, s.fields) == ("DATA ACCEL", {"joint": "A", "acceleration": 3})

    def test_motion(self):
        assert one("DATA MOTION (J) = -90.0").fields == {"joint": "J", "motions": [-90.0]}
        assert one("DATA MOTION (J) = RAMP").fields["motions"] == ["RAMP"]
        assert one("DATA MOTION (J) = 30.0, NONE").fields["motions"] == [30.0, None]

    def test_ic(self):
        assert one("DATA IC (J) = -90, 12.566").fields == {"joint": "J",
                                                           "pairs": [(-90, 12.566)]}
        assert one("DATA IC (J) = POS VEL").fields["pairs"] == [("POS", "VEL")]
        s = one("DATA IC (J) = 30,12.566; NONE, NONE")
        assert s.fields["pairs"] == [(30, 12.566), (None, None)]

    def test_time(self):
        s = one("DATA TIME 6,1,1")
        assert (s.kind, s.keyword) == ("DATA", "DATA TIME")
        assert s.fields == {"final": 6, "minstep": 1, "printstep": 1}

    def test_view_and_draw(self):
        s = one("DATA VIEW = 10, 10, 10; 0, 1, 0")
        assert s.fields == {"view": None, "eye": (10, 10, 10), "up": (0, 1, 0)}
        assert one("DATA VIEW = ISOMETRIC").fields["view"] == "ISOMETRIC"
        assert one("DATA DRAW = 50").fields == {"distance": 50}

    def test_all_37_data_keywords_parse(self):
        assert len(DATA_KEYWORDS) == 37

    def test_undocumented_or_absent_data_forms_are_explained(self):
        assert "never documented" in str(err("DATA SHAPE (L) = S"))
        assert "ZERO (POSITION)" in str(err("DATA ZERO (POSITION) = 0.001"))
        assert "DATA LINK" in str(err("DATA FLAT (J) = 0,0,0"))


# --------------------------------------------------------------------------- requests


class TestRequests:
    @pytest.mark.parametrize("family", ["PRINT", "LIST", "STORE", "PLOT"])
    @pytest.mark.parametrize("quantity", ["VALUE", "POSITION", "VELOCITY", "ACCEL", "FORCE"])
    def test_name_list_requests(self, family, quantity):
        s = one(f"{family} {quantity} (J1, P2)")
        assert (s.kind, s.keyword) == ("REQUEST", f"{family} {quantity}")
        assert s.fields == {"family": family, "quantity": quantity, "names": ["J1", "P2"],
                            "all": False}

    def test_all(self):
        s = one("PRINT POSITION (ALL)")
        assert s.fields["all"] is True and s.fields["names"] == []

    def test_heading_and_frequency(self):
        assert one("PRINT HEADINGS").keyword == "PRINT HEADING"
        assert one("STORE HEADING").keyword == "STORE HEADING"
        assert one("PRINT FREQUENCY").fields == {"family": "PRINT", "quantity": "FREQUENCY"}

    @pytest.mark.parametrize("text", ["LIST HEADING", "PLOT HEADING", "LIST FREQUENCY",
                                      "STORE FREQUENCY", "PLOT FREQUENCY"])
    def test_requests_that_do_not_exist(self, text):
        assert "there is no" in str(err(text))

    @pytest.mark.parametrize("family", ["PRINT", "STORE"])
    def test_print_and_store_dynamics(self, family):
        s = one(f"{family} DYNAMICS (FORCE, F1, 0) = POSITION, J2; ACCEL, P3")
        assert s.keyword == f"{family} DYNAMICS"
        assert s.fields == {"family": family, "quantity": "DYNAMICS", "input": "FORCE",
                            "namein": "F1", "nin": 0,
                            "pairs": [("POSITION", "J2"), ("ACCEL", "P3")]}
        s = one(f"{family} DYNAMICS (FORCE, F1) = VELOCITY, J2")
        assert s.fields["nin"] == 0

    @pytest.mark.parametrize("family", ["LIST", "PLOT"])
    def test_list_and_plot_dynamics(self, family):
        s = one(f"{family} DYNAMICS (1, 100, 0.5 / MOTION, J1, 1) = POSITION, J2")
        assert s.fields == {"family": family, "quantity": "DYNAMICS", "w0": 1, "wf": 100,
                            "winc": 0.5, "input": "MOTION", "namein": "J1", "nin": 1,
                            "pairs": [("POSITION", "J2")]}

    def test_dynamics_motion_needs_the_variable_index(self):
        assert "variable index" in str(err("PRINT DYNAMICS (MOTION, J1) = POSITION, J2"))


# --------------------------------------------------------------------------- control


class TestControl:
    def test_remark(self):
        s = one("REMARK: this - is (free) text, 'quoted' & odd ?!")
        assert (s.kind, s.keyword) == ("CONTROL", "REMARK")
        assert s.fields["text"] == "this - is (free) text, 'quoted' & odd ?!"

    def test_title(self):
        assert one("TITLE = Four-bar: test #1").fields["title"] == "Four-bar: test #1"
        s = one("TITLE " + "X" * 70)
        assert len(s.fields["title"]) == 63 and s.warnings
        s = one("TITLE = FOUR BAR $ a remark\nCLEAR")
        assert s.fields["title"] == "FOUR BAR CLEAR"
        assert any("continued" in w for w in s.warnings)

    @pytest.mark.parametrize("word", ["CLEAR", "EXECUTE", "RESET", "END", "RETURN"])
    def test_bare_control_words(self, word):
        s = one(word)
        assert (s.kind, s.keyword) == ("CONTROL", word)

    def test_execute_hold(self):
        s = one("EXECUTE HOLD")
        assert (s.keyword, s.fields["hold"]) == ("EXECUTE HOLD", True)
        assert one("EXECUTE").fields["hold"] is False

    def test_find(self):
        assert one("FIND EQUILIBRIUM").keyword == "FIND EQUILIB"
        assert one("FIND DYNAMICS").keyword == "FIND DYNAMICS"

    def test_print_input_and_print_on_off(self):
        assert one("PRINT INPUT").keyword == "PRINT INPUT"
        s = one("PRINT ON = out/run-1.prt")
        assert (s.kind, s.keyword, s.fields) == ("CONTROL", "PRINT ON",
                                                 {"filename": "out/run-1.prt"})
        assert one("PRINT ON").fields["filename"] is None
        assert one("PRINT OFF").keyword == "PRINT OFF"

    def test_store_and_recall_input(self):
        assert one("STORE INPUT = saved.dat").fields == {"filename": "saved.dat"}
        assert one("STORE INPUT").fields == {"filename": None}
        s = one("recall input loader.dat", expand_recall=False)
        assert (s.keyword, s.fields["filename"]) == ("RECALL INPUT", "loader.dat")

    def test_unit_mass(self):
        s = one("UNIT (MASS) = 1.0")
        assert (s.keyword, s.fields) == ("UNIT MASS", {"value": 1.0})

    @pytest.mark.parametrize("word", ["PAUSE", "ERASE"])
    def test_on_off_switches(self, word):
        assert one(f"{word} ON").keyword == f"{word} ON"
        s = one(f"{word} OFF")
        assert (s.kind, s.keyword) == ("CONTROL", f"{word} OFF")

    def test_identify(self):
        s = one("IDENTIFY: JOINTS, link, ZEROES, BOGUS, ALL")
        assert s.fields["types"] == ["JOINTS", "LINKS", "ZEROES", "ALL"]
        assert any("BOGUS" in w for w in s.warnings)

    @pytest.mark.parametrize("kind", ["DATA", "SYSTEM", "INERTIA", "SPRING", "INDETERM", "ZERO"])
    def test_zero_single_tolerance(self, kind):
        s = one(f"ZERO ({kind}) = 0.0001")
        assert (s.kind, s.keyword, s.fields) == ("CONTROL", f"ZERO {kind}",
                                                 {"tolerance": 0.0001})

    @pytest.mark.parametrize("kind", ["POSITION", "EQUILIB"])
    def test_zero_with_step_count(self, kind):
        assert one(f"ZERO ({kind}) = 0.001, 30").fields == {"tolerance": 0.001, "nsteps": 30}
        s = one(f"ZERO {kind} 0.000001")
        assert s.fields == {"tolerance": 1e-6, "nsteps": None} and not s.warnings

    def test_zero_force(self):
        s = one("ZERO FORC=20.0,5.0")
        assert (s.keyword, s.fields) == ("ZERO FORCE", {"force_error": 20.0,
                                                        "percent_error": 5.0, "nsteps": None})
        s = one("ZERO (FORCE) = 0.1, 1, 20000")  # openimp: the cap on a run's steps
        assert s.fields == {"force_error": 0.1, "percent_error": 1.0, "nsteps": 20000}


# --------------------------------------------------------------------------- DELETE


class TestDelete:
    @pytest.mark.parametrize("what", ["VALUE", "SOLID", "CONTACT", "LINK", "JOINT", "POINT",
                                      "MASS", "SPRING", "DAMPER", "FORCE", "TORQUE", "INPUT",
                                      "MOTION", "IC"])
    def test_name_lists(self, what):
        s = one(f"DELETE {what} (N1, N2)")
        assert (s.kind, s.keyword) == ("DELETE", f"DELETE {what}")
        assert s.fields == {"names": ["N1", "N2"], "all": False}
        assert one(f"DELETE {what} (ALL)").fields == {"names": [], "all": True}

    @pytest.mark.parametrize("what", ["TITLE", "GRAVITY", "VIEW", "EQUILIB", "DYNAMICS"])
    def test_bare_forms(self, what):
        s = one(f"DELETE {what}")
        assert (s.kind, s.keyword, s.fields) == ("DELETE", f"DELETE {what}", {})

    @pytest.mark.parametrize("family", ["PRINT", "LIST", "STORE", "PLOT"])
    def test_request_kinds(self, family):
        s = one(f"DELETE {family} (VALUE, POSITIONS)")
        assert s.fields == {"kinds": ["VALUE", "POSITION"], "all": False}
        assert one(f"DELETE {family} ALL").fields["all"] is True

    def test_special_cases(self):
        assert one("DELETE PRINT (INPUT)").fields["kinds"] == ["INPUT"]
        assert one("DELETE STORE (INPUT)").fields["kinds"] == ["INPUT"]
        assert one("DELETE INPUT (ALL)").fields["all"] is True
        assert one("DELETE EQUILIBRIUM").keyword == "DELETE EQUILIB"
        assert "INPUT" in str(err("DELETE LIST (INPUT)"))

    def test_delete_needs_names(self):
        assert "at least one name" in str(err("DELETE LINK"))


# --------------------------------------------------------------------------- graphics


class TestGraphics:
    def test_device(self):
        s = one("DEVICE = GRAPHIC")
        assert (s.kind, s.keyword, s.fields) == ("GRAPHICS", "DEVICE", {"device": "GRAPHIC"})

    @pytest.mark.parametrize("word", ["DRAW", "ANIMATE"])
    def test_draw_animate(self, word):
        assert (one(word).kind, one(word).keyword) == ("GRAPHICS", word)

    def test_show(self):
        s = one("SHOW(RED)=L2,L3")
        assert s.fields == {"color": "RED", "names": ["L2", "L3"], "all": False, "loops": []}
        assert one("SHOW AQUA = ALL").fields["color"] == "CYAN"
        assert one("SHOW VIOLET = ALL").fields["color"] == "MAGENTA"
        assert one("SHOW (GREEN) = LOOP 2").fields["loops"] == [2]
        s = one("SHOW (PINK) = L1")
        assert s.fields["color"] == "WHITE" and s.warnings

    def test_erase(self):
        s = one("ERASE (L1, LOOP 3)")
        assert s.fields == {"names": ["L1"], "all": False, "loops": [3], "clear": False}
        assert one("ERASE").fields["clear"] is True

    def test_axes(self):
        assert one("AXES 1 ALL").fields == {"length": 1, "names": [], "all": True}
        assert one("AXES 0 ALL").fields["length"] == 0
        assert one("AXES (2.5) = J1, J2").fields == {"length": 2.5, "names": ["J1", "J2"],
                                                     "all": False}

    def test_zoom(self):
        assert one("ZOOM(0.7)").fields == {"power": 0.7, "center": None}
        assert one("ZOOM (2) = 1, 2, 3").fields == {"power": 2, "center": (1, 2, 3)}
        assert one("ZOOM").fields["power"] == 0

    def test_slide_and_turn(self):
        assert one("SLIDE (Y)=-20").fields == {"axis": "Y", "distance": -20}
        assert one("slide x 5.0").fields == {"axis": "X", "distance": 5}
        assert one("TURN (Z) = 30").fields == {"axis": "Z", "angle": 30}
        assert "XSLIDE" in str(err("SLIDER (A, B) = C"))

    def test_store_recall_view(self):
        s = one("STORE VIEW")
        assert (s.kind, s.keyword, s.fields) == ("GRAPHICS", "STORE VIEW", {"number": None})
        assert one("RECALL VIEW = -7").fields["number"] == -7


# --------------------------------------------------------------------------- keyword tables


def test_leading_keyword_table_is_complete_and_unambiguous():
    assert len(LEADING_KEYWORDS) == 61  # 21 joints + 40 others, no 4-letter clash


# --------------------------------------------------------------------------- errors


class TestErrors:
    def test_error_prints_file_and_line(self):
        e = err("CLEAR\n\nZPIN (A, B)\n")
        assert e.where == ("deck.imp", 3)
        assert str(e).startswith("deck.imp:3: ZPIN statement:")
        assert "joint name is missing" in str(e)
        assert "ZPIN (link1, link2) = joint" in str(e)

    def test_unknown_keyword(self):
        e = err("FROB (A) = B")
        assert "unknown statement keyword 'FROB'" in str(e)
        assert "XPIN" in str(err("PIN (A, B) = C"))
        assert "did you mean EXECUTE" in str(err("EXCUTE"))

    def test_statement_must_start_with_a_word(self):
        assert "starts with a keyword" in str(err("3.5, A"))

    def test_too_few_names(self):
        assert "second link is missing" in str(err("ZPIN (A) = "))
        assert "spring name is missing" in str(err("SPRING (P1, P2)"))

    def test_too_many_items(self):
        e = err("ZPIN (A, B) = C, D")
        assert "the name D is one item too many" in str(e)
        assert "one item too many" in str(err("DATA RACK (R) = 1, 2"))
        assert "one item too many" in str(err("EXECUTE NOW"))

    def test_number_where_a_name_is_expected(self):
        assert "found the number 3" in str(err("ZPIN (A, 3) = C"))
        e = err("POINT (L) = A, , B")
        assert "implied by two separators" in str(e)

    def test_bad_numbers(self):
        assert "out of range" in str(err("DATA RACK (R) = 1E999"))
        e = err("DATA RACK (R) = ABC")
        assert "expected a number for the pinion pitch radius, found the name ABC" in str(e)
        assert "expected a number" in str(err("DATA ZPIN (J) = 1, 2, X, 4"))

    def test_unexpected_character(self):
        e = err("ZPIN (A, B) = C#")
        assert "unexpected character '#'" in str(e)

    def test_unbalanced_parentheses(self):
        assert "parentheses do not balance" in str(err("VALUE (V) = (1 + 2"))
        assert "parentheses do not balance" in str(err("VALUE (V) = 1 + 2)"))
        assert "parentheses do not balance" in str(err("VALUE (V) = SIN(T"))

    def test_missing_equals(self):
        e = err("VALUE (V) 2*T")
        assert "'=' is missing" in str(e)
        assert "VALUE (name) = expression" in str(e)

    @pytest.mark.parametrize("expr, words", [
        ("-PI", "no unary minus"),
        ("-(2.5)", "no unary minus"),
        ("2 T", "operator"),
        ("2 +", "ends where"),
        ("", "empty"),
        ("ATAN(1)", "two arguments"),
        ("SIN 2", "parentheses"),
        ("POSITION(3, 1)", "element name"),
        ("POSITION(J1)", "component"),
        ("IF(T 1, 2, 3)", "':'"),
        ("TABLE(T)", "':'"),
        ("2 * = 3", "expected a number, name or '('"),
    ])
    def test_bad_expressions(self, expr, words):
        e = err(f"VALUE (V) = {expr}")
        assert words in str(e)
        assert str(e).startswith("deck.imp:1:")

    def test_deep_expressions_are_refused_not_crashing(self):
        deep = "VALUE (V) = " + "$\n".join(["((((((((((" ] * 6) + "1"
        assert "nested more than" in str(err(deep))
        long = "VALUE (V) = " + "$\n".join(["1+1+1+1+1+1+1+1+1+1+1+1+1+1+1+1+"] * 30) + "1"
        assert "too long" in str(err(long))
        chain = "\n".join(f"VALUE (V{i}) = V{i + 1} + 1" for i in range(200))
        env = {s.fields["name"]: s.fields["expression"] for s in parse_text(chain,
                                                                            significant=None)}
        env["V200"] = 0.0
        assert env["V150"].evaluate(env) == 50.0
        with pytest.raises(InputError, match="more than 50 deep"):
            env["V0"].evaluate(env, strict=True)

    def test_bad_expression_error_is_on_the_continuation_line(self):
        e = err("VALUE (V) = 1 + $\n 2 * ")
        assert e.where == ("deck.imp", 2)

    def test_request_errors(self):
        assert "at least one name" in str(err("PRINT POSITION"))
        assert "what to list" in str(err("LIST (A)"))

    def test_on_error_collects_and_continues(self):
        errors: list[InputError] = []
        stmts = parse_text("CLEAR\nFROB\nZPIN (A,B)\nEXECUTE\n", "d.imp", on_error=errors.append)
        assert [s.keyword for s in stmts] == ["CLEAR", "EXECUTE"]
        assert [e.where for e in errors] == [("d.imp", 2), ("d.imp", 3)]

    def test_parse_statement_interactive(self):
        assert parse_statement("  $$ nothing") is None
        assert parse_statement("exec hold").keyword == "EXECUTE HOLD"
        with pytest.raises(InputError):
            parse_statement("DATA")


# --------------------------------------------------------------------------- fuzz


_FUZZ_WORDS = [*{v for v in LEADING_KEYWORDS.values()}, *DATA_KEYWORDS.values(), "ALL", "NONE",
               "LINK", "ABS", "HOLD", "INPUT", "ON", "OFF", "SIN", "TABLE", "IF", "POSITION",
               "T", "PI", "A", "J1", "P", "LOOP", "RED", "X"]
_FUZZ_BITS = [" ", ",", ";", "/", ":", "=", "(", ")", "+", "-", "*", "@", "$", "$$", ".", "1",
              "-.5", "2.5E3", "3.8.0", "1E999", "'", "#", "\t", "E", "e-", "  "]


_FUZZ_TEMPLATES = [
    "ZPIN (BASE, CRNK) = A", "DATA ZPIN (A) = 0,0,0; 1,0,0; 1,2,0", "POINT (L) = P, Q",
    "DATA POINT (P, LINK) = 1, 2, 3", "DATA SPRING (S) = NONE, 3; K, 4", "PRINT POSITION (ALL)",
    "LIST DYNAMICS (1, 10, 1 / FORCE, F, 0) = POSITION, J", "VALUE (V) = IF(T-1: 2, SIN(T), 3)",
    "VALUE (W) = 2*POSITION(J1, 1)@2 - ATAN2(1, T)", "SHOW (RED) = L1, LOOP 2", "ZOOM (2) = 1,2,3",
    "DELETE PRINT (VALUE, ALL)", "ZERO (POSITION) = 0.001, 20", "TITLE = A - B", "EXECUTE HOLD",
    "IDENTIFY JOINTS", "DATA TIME = 1, 0.1, 0.1", "DATA IC (J) = 1, 2; NONE, NONE", "AXES 1 ALL",
]


def _mutate(rng: random.Random, text: str) -> str:
    chars = list(text)
    for _ in range(rng.randint(0, 2)):
        i = rng.randrange(len(chars) + 1)
        r = rng.random()
        if r < 0.4 and i < len(chars):
            del chars[i]
        elif r < 0.8:
            chars.insert(i, rng.choice("(),;:=+-*/@$. 0123456789AZaz#'"))
        elif i < len(chars):
            chars[i] = chr(rng.randint(32, 126))
    return "".join(chars)


def _fuzz_line(rng: random.Random) -> str:
    if rng.random() < 0.5:
        return _mutate(rng, rng.choice(_FUZZ_TEMPLATES))
    parts = []
    if rng.random() < 0.8:
        parts.append(rng.choice(_FUZZ_WORDS))
        if rng.random() < 0.5:
            parts.append(" " + rng.choice(_FUZZ_WORDS))
    for _ in range(rng.randint(0, 14)):
        r = rng.random()
        if r < 0.35:
            parts.append(rng.choice(_FUZZ_BITS))
        elif r < 0.65:
            parts.append(rng.choice(_FUZZ_WORDS))
        elif r < 0.9:
            parts.append(f"{rng.uniform(-1e3, 1e3):.{rng.randint(0, 4)}f}")
        else:
            parts.append(chr(rng.randint(0, 255)))
    sep = rng.choice(["", " ", ","])
    return sep.join(parts)


def test_fuzz_parsing_raises_only_input_errors(tmp_path):
    rng = random.Random(20240607)
    parsed = 0
    for _ in range(3000):
        text = "\n".join(_fuzz_line(rng) for _ in range(rng.randint(1, 3)))
        try:
            stmts = parse_text(text, "fuzz.imp", base_dir=str(tmp_path))
        except InputError as exc:
            assert exc.where is None or exc.where[0] in ("fuzz.imp",) or \
                str(tmp_path) in exc.where[0]
            continue
        parsed += 1
        for s in stmts:
            expr = s.fields.get("expression")
            if expr is None:
                continue
            try:
                expr.derivatives({}, lambda k, n, c: rng.uniform(-2, 2))
            except (InputError, SimulationStop):
                pass
    assert parsed > 400  # the generator produces valid statements too


def test_fuzz_expressions_evaluate_without_surprises():
    rng = random.Random(7)
    atoms = ["T", "PI", "2", "-.5", "0", "1E300", "V1", "SIN(T)", "SQRT(-1)", "LOG(0)",
             "ATAN2(0, 0)", "POSITION(J1, 1)", "VELOCITY(J1, 2.5)", "FORCE(S, 1)", "ACOS(2)",
             "IF(T-1: 1, 2, 3)", "EXP(1000)", "TAN(PI/2)", "(1@0.5)", "ABS(-3)", "USER(F)"]
    ops = ["+", "-", "*", "/", "@"]
    env = {"V1": 2.0}
    for _ in range(2000):
        text = rng.choice(atoms)
        for _ in range(rng.randint(0, 5)):
            text += rng.choice(ops) + rng.choice(atoms)
        expr = parse_expression(text, name="F")
        for resolve in (None, lambda k, n, c: 0.5):
            value = expr.derivatives(env, resolve)
            assert len(value) == 3 and all(isinstance(v, float) for v in value)


# --------------------------------------------------------------------------- expressions


def _resolver(t: float = 0.0, table: dict | None = None):
    table = table or {}

    def resolve(kind, name, comp):
        if kind == "TIME":
            return t
        return table.get((kind, name, comp), math.nan)

    return resolve


class TestExpressions:
    @pytest.mark.parametrize("text, value", [
        ("1 + 2 * 3", 7.0),
        ("10 - 2 - 3", 5.0),
        ("10 - 2 + 3", 11.0),
        ("2 + 10 - 3", 9.0),
        ("12 / 3 / 2", 2.0),
        ("12 / 3 * 2", 8.0),
        ("2 * 12 / 3", 8.0),
        ("2 @ 3 @ 2", 64.0),   # @ runs left to right
        ("2 * 3 @ 2", 18.0),
        ("-2 * -3", 6.0),
        ("0 - PI", -math.pi),
        ("-1*(2 + 3)", -5.0),
        ("ABS(-2.5)", 2.5),
        ("SQRT(16)", 4.0),
        ("EXP(0) + LOG(1) + LOG10(1000)", 4.0),
        ("ASIN(1) + ACOS(1)", math.pi / 2),
        ("TAN(PI/4)", 1.0),
        ("COS(0) + SIN(0)", 1.0),
        ("ATAN2(1, 1)", math.pi / 4),
        ("ATAN2(0, -1)", math.pi),
        ("ATAN2(0-1, 0)", -math.pi / 2),
        ("IF(0-1: 10, 20, 30)", 10.0),
        ("IF(0: 10, 20, 30)", 20.0),
        ("IF(2: 10, 20, 30)", 30.0),
        ("3.8.0 + 0", 3.8),
    ])
    def test_values(self, text, value):
        assert parse_expression(text).evaluate() == pytest.approx(value)

    @pytest.mark.parametrize("text, words", [
        ("1/0", "division by zero"),
        ("SQRT(0-1)", "SQRT"),
        ("LOG(0)", "LOG"),
        ("ASIN(2)", "[-1, 1]"),
        ("(0-2)@2", "base of '@'"),
        ("ATAN2(0, 0)", "ATAN2(0, 0)"),
        ("UNDEFD + 1", "not a defined VALUE"),
        ("EXP(1000)", "overflows"),
    ])
    def test_undefined_results(self, text, words):
        expr = parse_expression(text, name="BAD", file="d.imp", line=4)
        notes: list[str] = []
        assert math.isnan(expr.evaluate(notes=notes))
        assert words in notes[0]
        with pytest.raises(InputError) as info:
            expr.evaluate(strict=True)
        assert info.value.where == ("d.imp", 4)
        assert str(info.value).startswith("d.imp:4: VALUE (BAD):")

    def test_time_and_model_references_through_the_callback(self):
        table = {("POSITION", "JT5", 1): 0.5, ("VELOCITY", "JT5", 1): 2.0,
                 ("ACCEL", "JT5", 1): -1.0, ("POSITION", "P803", 2): 7.0,
                 ("FORCE", "SP", 1): 30.0}
        resolve = _resolver(t=1.5, table=table)
        assert parse_expression("TIME + T").evaluate(resolve=resolve) == 3.0
        assert parse_expression("POSIT(P803,2)").evaluate(resolve=resolve) == 7.0
        # the component is rounded to an integer
        assert parse_expression("POSITION(P803, 1.6)").evaluate(resolve=resolve) == 7.0
        assert parse_expression("POSITION(JT5, 1)").derivatives(resolve=resolve) == (0.5, 2, -1)
        v = parse_expression("VELOCITY(JT5, 1)").derivatives(resolve=resolve)
        assert v[:2] == (2.0, -1.0) and math.isnan(v[2])
        f = parse_expression("FORCE(SP, 1)").derivatives(resolve=resolve)
        assert f[0] == 30.0 and math.isnan(f[1])
        seen = []
        parse_expression("POSITION(JT5, 1)").evaluate(
            resolve=lambda k, n, c: seen.append(k) or 0.0)
        assert seen == ["POSITION"]  # a plain evaluation asks for the value only

    def test_user_function(self):
        """USER(name) calls the registered f(t, nderiv) at the resolver's TIME."""
        from openimp.imp import register_user

        resolve = lambda k, n, c: 2.0 if k == "TIME" else 0.0  # noqa: E731
        register_user("FUNC", lambda t, n: (5.0 * t, 6.0, 7.0)[n])
        try:
            assert parse_expression("USER(FUNC)").derivatives(resolve=resolve) == (10, 6, 7)
            assert math.isnan(parse_expression("USER(FUNC)").evaluate())  # no time
        finally:
            register_user("FUNC", None)
        assert math.isnan(parse_expression("USER(FUNC)").evaluate(resolve=resolve))

    def test_references_and_names(self):
        expr = parse_expression("A + POSITION(JT5, 1) * B + USER(F) + FORCE(SP, 1) + T")
        assert expr.value_names() == ["A", "B"]
        assert expr.references() == [("FORCE", "SP"), ("POSITION", "JT5"), ("USER", "F")]
        assert expr.uses_time()

    @pytest.mark.parametrize("text, jet", [
        ("3*T@2", lambda t: (3 * t * t, 6 * t, 6.0)),
        ("SIN(2*T)", lambda t: (math.sin(2 * t), 2 * math.cos(2 * t), -4 * math.sin(2 * t))),
        ("1/T", lambda t: (1 / t, -1 / t**2, 2 / t**3)),
        ("SQRT(T)*EXP(T/4)", None),
        ("ATAN2(SIN(T), COS(T)*2) - LOG(T) + ABS(0-T) + TAN(T/3) + ASIN(T/4) + ACOS(T/5)", None),
        ("T@T + LOG10(T)", None),
    ])
    def test_time_derivatives(self, text, jet):
        expr = parse_expression(text)
        t = 1.3
        got = expr.derivatives(resolve=_resolver(t))
        if jet is not None:
            assert got == pytest.approx(jet(t))
        h = 1e-4
        f = [expr.evaluate(resolve=_resolver(t + k * h)) for k in (-1, 0, 1)]
        assert got[1] == pytest.approx((f[2] - f[0]) / (2 * h), rel=1e-6)
        assert got[2] == pytest.approx((f[2] - 2 * f[1] + f[0]) / h**2, rel=1e-4)

    def test_environment_of_values(self):
        stmts = parse_text("VALUE (RATE) = 2\nVALUE (ANGLE) = RATE*T\n"
                           "VALUE (DRIVE) = SIN(ANGLE)\nVALUE (C) = 2.5\n")
        env = {s.fields["name"]: s.fields["expression"] for s in stmts}
        jet = env["DRIV"].derivatives(env, _resolver(0.5))
        assert jet == pytest.approx((math.sin(1), 2 * math.cos(1), -4 * math.sin(1)))
        env["C"] = 4.0
        assert parse_expression("C*2").evaluate(env) == 8.0
        env["C"] = (1.0, 2.0, 3.0)
        assert parse_expression("C*2").derivatives(env) == (2, 4, 6)

    def test_value_cycle_is_undefined(self):
        stmts = parse_text("VALUE (A) = B + 1\nVALUE (B) = A * 2\n", "cyc.imp")
        env = {s.fields["name"]: s.fields["expression"] for s in stmts}
        assert math.isnan(env["A"].evaluate(env))
        with pytest.raises(InputError, match="refers to itself"):
            env["A"].evaluate(env, strict=True)

    def test_if_is_lazy_and_return_end_stop_the_run(self):
        expr = parse_expression("IF(T - 1: 0, 0, RETURN)", file="s.imp", line=3)
        assert expr.evaluate(resolve=_resolver(0.5)) == 0.0
        with pytest.raises(SimulationStop) as info:
            expr.evaluate(resolve=_resolver(2.0))
        assert (info.value.kind, info.value.where) == ("RETURN", ("s.imp", 3))
        with pytest.raises(SimulationStop) as info:
            parse_expression("END").evaluate()
        assert info.value.kind == "END"

    def test_time_without_resolver_is_undefined(self):
        with pytest.raises(InputError, match="TIME"):
            parse_expression("T").evaluate(strict=True)

    def test_callback_errors_are_located(self):
        def resolve(kind, name, comp):
            raise InputError(f"no joint {name}")

        with pytest.raises(InputError) as info:
            parse_expression("POSITION(JX, 1)", file="r.imp", line=9).evaluate(resolve=resolve)
        assert info.value.where == ("r.imp", 9)


class TestTables:
    def _write(self, path: Path, xmin: float, xmax: float, ys) -> None:
        path.write_text("\n".join(str(v) for v in (xmin, xmax, *ys)) + "\n")

    def test_fourier_interpolation_is_exact_for_a_sampled_harmonic(self, tmp_path):
        n = 12
        period = 2 * math.pi
        ys = [1 + 2 * math.sin(k * period / n) + 0.5 * math.cos(2 * k * period / n)
              for k in range(n)]
        self._write(tmp_path / "cam.tab", 0.0, period, ys)
        deck = tmp_path / "deck.imp"
        deck.write_text("VALUE (PROF) = TABLE(T): cam.tab\nDATA CAM (J) = PROF\n")
        stmts = parse_file(deck)
        expr = stmts[0].fields["expression"]
        table = expr.table()
        assert table is not None and len(table.ordinates) == n
        for x in (0.0, 0.3, 2.0, 5.5, 2 * math.pi + 0.3, -1.0):
            want = 1 + 2 * math.sin(x) + 0.5 * math.cos(2 * x)
            assert table(x) == pytest.approx(want, abs=1e-12)
            jet = expr.derivatives(resolve=_resolver(x))
            assert jet == pytest.approx((want, 2 * math.cos(x) - math.sin(2 * x),
                                         -2 * math.sin(x) - 2 * math.cos(2 * x)), abs=1e-9)
        # the ordinates are reproduced at their sample points
        for x, y in zip(table.sample_points(), ys):
            assert table(x) == pytest.approx(y, abs=1e-12)

    def test_table_inside_a_larger_expression_is_not_a_cam_table(self, tmp_path):
        self._write(tmp_path / "t.tab", 0, 1, [1, 2, 3, 4])
        expr = parse_text("VALUE (V) = 2 * TABLE(T): t.tab + 1", base_dir=str(tmp_path))[0]
        e = expr.fields["expression"]
        assert e.table() is None
        assert e.evaluate(resolve=_resolver(0.25)) == pytest.approx(2 * 2 + 1)
        assert len(e.load_tables()) == 1

    def test_bad_table_files(self, tmp_path):
        self._write(tmp_path / "bad.tab", 1, 1, [1])
        with pytest.raises(InputError, match="greater than"):
            load_table(tmp_path / "bad.tab")
        (tmp_path / "junk.tab").write_text("0\n1\nabc\n")
        with pytest.raises(InputError) as info:
            load_table(tmp_path / "junk.tab")
        assert info.value.where == (str(tmp_path / "junk.tab"), 3)
        expr = parse_expression("TABLE(T): missing.tab", file="m.imp", base_dir=str(tmp_path))
        with pytest.raises(InputError, match="cannot be read") as info:
            expr.evaluate(resolve=_resolver(0.0))
        assert info.value.where == ("m.imp", 1)


# --------------------------------------------------------------------------- RECALL INPUT


class TestRecall:
    def test_recall_expands_with_own_file_and_line(self, tmp_path):
        (tmp_path / "sub").mkdir()
        (tmp_path / "sub" / "loads.dat").write_text(
            "REMARK first chunk\nDATA FORCE (F1) = 10\nRETURN\n"
            "REMARK second chunk\nDATA FORCE (F1) = 20\nRETURN\nREMARK third, unterminated\n")
        deck = tmp_path / "main.imp"
        deck.write_text("CLEAR\nRECALL INPUT = sub/loads.dat\nEXECUTE\nRECALL INPUT\n"
                        "RECALL INPUT\nRECALL INPUT\nEND\n")
        stmts = parse_file(deck)
        sub = str(tmp_path / "sub" / "loads.dat")
        got = [(s.keyword, os.path.basename(s.file), s.line) for s in stmts]
        assert got == [
            ("CLEAR", "main.imp", 1),
            ("RECALL INPUT", "main.imp", 2),
            ("REMARK", "loads.dat", 1), ("DATA FORCE", "loads.dat", 2), ("RETURN", "loads.dat", 3),
            ("EXECUTE", "main.imp", 3),
            ("RECALL INPUT", "main.imp", 4),
            ("REMARK", "loads.dat", 4), ("DATA FORCE", "loads.dat", 5), ("RETURN", "loads.dat", 6),
            ("RECALL INPUT", "main.imp", 5),
            ("REMARK", "loads.dat", 7), ("RETURN", "loads.dat", 7),
            ("RECALL INPUT", "main.imp", 6),
            ("RETURN", "loads.dat", 7),
            ("END", "main.imp", 7),
        ]
        assert stmts[1].fields["path"] == sub
        assert stmts[4].fields == {"ends_recall": True, "simulated": False}
        simulated = stmts[12]
        assert simulated.fields == {"ends_recall": True, "simulated": True}
        assert simulated.warnings == ["RETURN statement simulated at end of file."]

    def test_recall_can_be_left_unexpanded(self, tmp_path):
        stmts = parse_text("RECALL INPUT = nowhere.dat\nEXECUTE\n", expand_recall=False)
        assert [s.keyword for s in stmts] == ["RECALL INPUT", "EXECUTE"]

    def test_missing_recall_file(self, tmp_path):
        e = err("CLEAR\nRECALL INPUT = nowhere.dat\n", base_dir=str(tmp_path))
        assert e.where == ("deck.imp", 2)
        assert "cannot be read" in str(e)
        assert "none was recalled yet" in str(err("RECALL INPUT"))

    def test_recursive_recall_is_stopped(self, tmp_path):
        (tmp_path / "self.dat").write_text("RECALL INPUT = self.dat\n")
        with pytest.raises(InputError, match="recalls itself"):
            parse_file(tmp_path / "self.dat")
        # through another file, and deeper than the limit without recursion
        (tmp_path / "a.dat").write_text("RECALL INPUT = b.dat\n")
        (tmp_path / "b.dat").write_text("RECALL INPUT = a.dat\n")
        with pytest.raises(InputError, match=r"recalls itself \('a.dat' -> 'b.dat' -> 'a.dat'"):
            parse_file(tmp_path / "a.dat")
        for k in range(20):
            (tmp_path / f"n{k}.dat").write_text(f"RECALL INPUT = n{k + 1}.dat\n")
        (tmp_path / "n20.dat").write_text("CLEAR\n")
        with pytest.raises(InputError, match="nested more than 16 deep"):
            parse_file(tmp_path / "n0.dat")

    def test_end_stops_reading_in_a_recalled_file_too(self, tmp_path):
        (tmp_path / "quit.dat").write_text("CLEAR\nEND\nGARBAGE ###\n")
        stmts = parse_text("RECALL INPUT = quit.dat\nEXECUTE\n", base_dir=str(tmp_path))
        assert [s.keyword for s in stmts] == ["RECALL INPUT", "CLEAR", "END"]


# --------------------------------------------------------------------------- whole deck


def test_four_bar_deck_end_to_end():
    path = DECKS / "parse_fourbar.imp"
    stmts = parse(path)
    assert stmts == parse(str(path)) == parse(path.read_text(), file=str(path),
                                             base_dir=str(path.parent))
    assert [s.keyword for s in stmts] == [
        "TITLE", "REMARK", "GROUND", "ZPIN", "ZPIN", "ZPIN", "ZPIN", "POINT", "POINT",
        "DATA ZPIN", "DATA ZPIN", "DATA ZPIN", "DATA ZPIN", "DATA POINT", "DATA POINT",
        "DATA POINT", "SPRING", "DATA SPRING", "DAMPER", "DATA DAMPER", "FORCE", "DATA FORCE",
        "DATA MASS", "DATA INERTIA", "DATA GRAVITY", "VALUE", "DATA POSITION",
        "DATA VELOCITY", "DATA TIME", "PRINT HEADING", "PRINT POSITION", "PRINT VALUE",
        "LIST POSITION", "LIST FORCE", "EXECUTE", "END",
    ]
    by_kind: dict[str, int] = {}
    for s in stmts:
        by_kind[s.kind] = by_kind.get(s.kind, 0) + 1
        assert s.file == str(path)
    assert by_kind == {"CONTROL": 4, "DEFINE": 10, "DATA": 16, "VALUE": 1, "REQUEST": 5}
    title = stmts[0]
    assert title.fields["title"] == "FOUR-BAR LINKAGE, KINEMATIC SWEEP OF THE CRANK"
    joints = {s.fields["joint"]: (s.fields["link1"], s.fields["link2"])
              for s in stmts if s.kind == "DEFINE" and s.keyword == "ZPIN"}
    assert joints == {"A": ("BASE", "CRNK"), "B": ("CRNK", "CPLR"), "C": ("CPLR", "ROCK"),
                      "D": ("ROCK", "BASE")}
    crank = stmts[3]
    assert (crank.line, crank.remarks) == (5, ["input crank pivot"])
    data_b = stmts[10]
    assert (data_b.line, data_b.end_line) == (12, 13)
    assert data_b.fields["points"] == [(1, 2, 0), (2, 4, 0), (4, 3, 0)]
    assert stmts[7].fields["points"] == ["P", "PB", "P"]
    assert stmts[14].fields["coords"] == (-0.232, 0.5, 0)
    assert stmts[22].fields["center"] == (1.5, 0.5, 0.0)
    assert stmts[23].fields["inertia"] == (0.1, 0.2, 0.3, 0, 0, 0)
    assert stmts[23].warnings == ["Warning: 3 zeroes are added to complete statement."]
    value = stmts[25].fields["expression"]
    assert value.evaluate(resolve=_resolver(0.5)) == pytest.approx(math.pi)
    assert stmts[26].fields == {"joint": "A", "start": 0, "increment": 15, "nsteps": 24}
    assert stmts[30].fields["names"] == ["A", "B", "C", "D", "P"]
    assert all(not s.warnings for i, s in enumerate(stmts) if i != 23)
