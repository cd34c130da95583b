"""The profile figure: a profile that was not computed is said in its panel, never drawn as a lone dot (issue 43,
the first hour)."""

from __future__ import annotations

from obsnl.identification.profile import Profile
from obsnl.report import figures


def test_a_profile_without_points_is_said_not_drawn(tmp_path, monkeypatch):
    said: list[str] = []
    plt = figures.agg_pyplot()
    real = plt.Axes.text

    def spy(self, x, y, s, *a, **k):
        said.append(s)
        return real(self, x, y, s, *a, **k)

    monkeypatch.setattr(plt.Axes, "text", spy)
    closed = Profile("k", 5.0e4, (49960.0, 50040.0), "closed", ((49950.0, 5.0), (50000.0, 0.0), (50050.0, 4.5)))
    missing = Profile("c", 10.0, (None, None), "not-computed", ((10.0, 0.0),), sides=("the time budget ran out", ""))
    out = figures.plot_profiles(tmp_path / "p.png", profiles=[closed, missing], threshold=3.84)
    assert out.exists()
    assert any("no profile" in s and "time budget ran out" in s.replace("\n", " ") for s in said)
    assert not any("no profile" in s and "k" == s for s in said)


def test_the_fit_figure_writes_the_units_of_an_output_where_the_model_gives_them(tmp_path, monkeypatch):
    import numpy as np

    from obsnl.report.identification import diagnostics

    labels: list[str] = []
    plt = figures.agg_pyplot()
    real = plt.Axes.set_ylabel
    monkeypatch.setattr(plt.Axes, "set_ylabel", lambda self, s, *a, **k: labels.append(s) or real(self, s, *a, **k))
    t = np.arange(200) * 0.01
    y = np.sin(t)[:, None]
    diagnostics.plot_fit_record(tmp_path / "fit.png", t=t, measured=y, simulated=0.99 * y, outputs=["disp"],
                                fit={"disp": 1.0}, units={"disp": "m"})
    assert "disp (m)" in labels and "residual of disp (m)" in labels
