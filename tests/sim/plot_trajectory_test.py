"""sim/plot_trajectory.py on a trajectory in excite-sim's format: a PNG with the
three panels; a file that is not a trajectory is refused with exit 1."""
import math
import pathlib
import subprocess
import sys
import tempfile

SCRIPT = pathlib.Path(__file__).resolve().parents[2] / "sim" / "plot_trajectory.py"


def run(*args):
    return subprocess.run([sys.executable, str(SCRIPT), *args], capture_output=True,
                          text=True, check=False)


def main():
    with tempfile.TemporaryDirectory() as tmp:
        csv = pathlib.Path(tmp) / "run.csv"
        lines = ["x0,x1,u0,x0_next,x1_next,sequence"]
        for k in range(50):
            x0, x1, u = math.sin(0.1 * k), math.cos(0.1 * k), (-1) ** k
            lines.append(f"{x0},{x1},{u},{x0 + 0.01},{x1 - 0.01},{k}")
        csv.write_text("\n".join(lines) + "\n")
        result = run(str(csv))
        assert result.returncode == 0, result.stderr
        assert "50 transitions plotted to" in result.stdout, result.stdout
        png = csv.with_suffix(".png")
        data = png.read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 20000, len(data)

        # The config's names, when excite-sim writes them, label the panels.
        named = pathlib.Path(tmp) / "named.csv"
        named.write_text("\n".join(["theta,theta_dot,tau,theta_next,theta_dot_next,sequence"]
                                   + lines[1:]) + "\n")
        sys.path.insert(0, str(SCRIPT.parent))
        import plot_trajectory  # noqa: E402
        steps, x, u, states, inputs = plot_trajectory.read_trajectory(str(named))
        assert (states, inputs) == (["theta", "theta_dot"], ["tau"]), (states, inputs)
        assert x.shape == (50, 2) and u.shape == (50, 1) and steps[-1] == 49
        assert run(str(named)).returncode == 0

        bad = pathlib.Path(tmp) / "bad.csv"
        bad.write_text("a,b\n1,2\n")
        result = run(str(bad))
        assert result.returncode == 1 and "not an excite-sim trajectory" in result.stderr, (
            result.stderr)
        assert run(str(pathlib.Path(tmp) / "missing.csv")).returncode == 1
    print("plot_trajectory: ok")


if __name__ == "__main__":
    main()
