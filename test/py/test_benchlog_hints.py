"""What the reader says of a header a spreadsheet or a hand edit changed (docs/bench-log.md):
the harmless variants (a BOM, CR LF line ends) read silently, and a header whose required
columns are there in another case, or behind another separator, quotes and decimal commas,
is refused in one message naming the file, the line and each fault with its fix."""
import pytest

from hpddo.logs.benchlog import BenchLogError, read_log

ROWS = "0.0,0.5,6.0,0.3,100.0\n0.5,0.5,6.1,0.31,101.0\n"


def _refusal(tmp_path, data: bytes):
    p = tmp_path / "export.csv"
    p.write_bytes(data)
    with pytest.raises(BenchLogError) as ei:
        read_log(p)
    return p, ei.value


def test_a_bom_and_crlf_line_ends_are_read_silently(tmp_path):
    p = tmp_path / "excel.csv"
    p.write_bytes(b"\xef\xbb\xbf# condition=x\r\nt_s,duty,v_V,i_A,rpm_ref\r\n" + ROWS.replace("\n", "\r\n").encode())
    log = read_log(p)
    assert list(log.df.columns) == ["t_s", "duty", "v_V", "i_A", "rpm_ref"]
    assert log.df["v_V"].tolist() == [6.0, 6.1] and log.lines.tolist() == [3, 4]


def test_columns_in_another_case_are_named_with_the_fix(tmp_path):
    p, e = _refusal(tmp_path, ("# condition=x\nT_s,Duty,V_V,I_A,rpm_ref\n" + ROWS).encode())
    msg = str(e)
    assert msg.startswith(f"{p}:2: missing required column(s) t_s, duty, v_V, i_A in header"), msg
    assert e.line == 2 and e.kind == "missing required column"
    assert "in another case, as T_s, Duty, V_V, I_A" in msg and "case-sensitive" in msg, msg
    assert "rename T_s, Duty, V_V, I_A to t_s, duty, v_V, i_A" in msg, msg
    assert "separated" not in msg and "decimal" not in msg, msg


def test_one_column_in_another_case_names_only_it(tmp_path):
    _, e = _refusal(tmp_path, ("t_s,duty,v_V,I_a\n0,0.5,6,0.3\n").encode())
    assert "missing required column(s) i_A in header" in str(e)
    assert "rename I_a to i_A" in str(e), str(e)


def test_a_spreadsheet_export_gets_every_hint_in_one_message(tmp_path):
    """UTF-8 BOM, CR LF, semicolons, decimal commas, Title-Case names: one message, the
    header's line, each fault and the fix."""
    text = "T_s;Duty;V_V;I_A;Rpm_ref\r\n0;0,5;6,0;0,3;100,0\r\n0,5;0,5;6,1;0,31;101,0\r\n"
    p, e = _refusal(tmp_path, b"\xef\xbb\xbf" + text.encode())
    msg = str(e)
    assert msg.startswith(f"{p}:1: missing required column(s) t_s, duty, v_V, i_A in header"), msg
    assert "separated by semicolons" in msg, msg
    assert "decimal commas ('0,5' on the next line)" in msg, msg
    assert "in another case, as T_s, Duty, V_V, I_A" in msg, msg
    assert "byte order mark and CR LF line ends the format accepts" in msg, msg
    assert "',' between columns and '.' in numbers" in msg and "rename T_s, Duty, V_V, I_A to t_s" in msg, msg
    assert "\n" not in msg


def test_semicolons_with_the_right_names_name_no_case(tmp_path):
    _, e = _refusal(tmp_path, b"t_s;duty;v_V;i_A\n0;0.5;6;0.3\n")
    msg = str(e)
    assert "separated by semicolons" in msg and "another case" not in msg and "numbers have decimal commas" not in msg, msg


def test_quoted_names_in_another_case(tmp_path):
    _, e = _refusal(tmp_path, b'"T_s","duty","v_V","i_A"\n0,0.5,6,0.3\n')
    msg = str(e)
    assert "in quotes" in msg and "as T_s " in msg + " ", msg


def test_a_header_really_missing_a_column_gets_no_hint(tmp_path):
    _, e = _refusal(tmp_path, b"t_s,duty,v_V,current\n0,0.5,6,0.3\n")
    assert str(e).endswith("missing required column(s) i_A in header"), str(e)
