"""Command-line conventions of CONTRACT.md that hold for every command."""


def test_unknown_command_exits_2_with_one_line(cli):
    rc, out, err = cli("no-such-command")
    assert rc == 2 and out == ""
    assert len(err.strip().splitlines()) == 1


def test_missing_geometry_file_named(cli):
    rc, out, err, obj = cli("reed", "missing.toml", "--json")
    assert rc == 2 and out == "" and obj is None
    assert "missing.toml" in err and len(err.strip().splitlines()) == 1
    assert "Traceback" not in err


def test_bad_geometry_field_named(cli, tmp_path):
    f = tmp_path / "r.toml"
    f.write_text(
        "[reed]\nlength=0.02\nthickness=-1e-3\nwidth_tip=0.01\n"
        "[reed.material]\nyoungs_modulus=2e11\ndensity=7800.0\npoisson_ratio=0.3\n"
    )
    rc, out, err, obj = cli("reed", f, "--json")
    assert rc == 2 and "reed.thickness" in err and "Traceback" not in err


def test_help_of_every_command_prints(capsys):
    """`valvelab --help` and `valvelab CMD --help` list and describe every command (no crash)."""
    import pytest

    from studies.cli import COMMANDS, main

    for argv in [["--help"]] + [[name, "--help"] for name in COMMANDS]:
        with pytest.raises(SystemExit) as exc:
            main(argv)
        assert exc.value.code == 0, argv
        out = capsys.readouterr().out
        assert "usage: valvelab" in out
        if argv == ["--help"]:
            assert all(name in out for name in COMMANDS)
