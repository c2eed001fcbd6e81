# %% [markdown]
# # pendtrack from Python
#
# The pipeline the CLI runs, from a notebook or a script, with `import pendtrack as pt` only.
# Two paths: the sample video to fits and discovery, and a measured table to discovery.
# Run it from the repository's root (`python docs/tutorial.py`, or open it with jupytext);
# the few starts below keep it short, the defaults (150 starts) are the paper's.

# %%
import pendtrack as pt

# %% [markdown]
# ## From the sample video
#
# `pt.track` runs the `track` stage (`pendtrack track`): the marker's centre in every frame, raw
# and lens-corrected [px]. Keyword options are the CLI's flags (`marker_color`, `projection`,
# `fov`, `roi`, ...); the sample is the paper's setup, so the defaults fit it. Every table
# carries its provenance in `.attrs["provenance"]`.

# %%
tr = pt.track("sample_videos/12na1.mp4")
th = pt.angle(tr)             # axle by circle fit, theta [rad], zero at rest
kin = pt.kinematics(th)       # Savitzky-Golay theta, omega, alpha and the paper's initial analysis
print(kin.attrs["provenance"]["extra"]["Omega0"], "rad/s, model-free")

# %% [markdown]
# `pt.fit` runs the `fit` stage: the same fit as `pendtrack fit`, to the last digit.
# The result shows as tables in a notebook, and `.plot()` draws the report's figure.

# %%
fits = pt.fit(kin, ["classic", "fractional"], starts=4, workers=1)  # workers=1: no process pool
print("selected:", fits.selected)
print(fits["fractional"].params)
fig = fits.plot()

# %% [markdown]
# `pt.discover` names what the baseline misses. `effects` limits the catalogue tried (all by default).

# %%
d = pt.discover(kin, effects=("power_drag", "memory"), workers=1)
print(d.effects)
print(d.verdict)

# %% [markdown]
# ## From a measured table
#
# A two-column table is read as t [s], theta [rad] (`columns=` names other layouts, as `--columns`).

# %%
rec = pt.read_record("../shared/data/real-tyler-phy180/lab2_trial1_rawdata.txt")
d2 = pt.discover(rec, effects=("power_drag", "memory"), workers=1)
print(d2.effects)
print(d2.verdict)

# %% [markdown]
# ## Simulating a model
#
# Any model `--model` names, here with the fitted values of the fractional fit.

# %%
values = {k: v for k, v in fits["fractional"].params["value"].items() if k != "theta_off"}
sim = pt.simulate("fractional", values, kin["t"].to_numpy(), theta0=float(kin["theta"].iloc[0]),
                  omega0=float(kin["omega"].iloc[0]))
print(sim.head())
