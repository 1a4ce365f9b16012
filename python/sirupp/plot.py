"""Drawing the arm in a notebook: a matplotlib 3D line drawing that always works (no display,
no server), and the lab panel's live 3D view in an IFrame when a panel runs."""
import numpy as np


def draw_arm(model, q, ax=None, color="tab:blue", frames=False, label=None):
    """Draws `model` at joint positions q in a 3D matplotlib axes (made when ax is None): the
    links as a polyline through the DH frame origins and the tool point, joints as dots, the
    tool's axes in red/green/blue, and with frames=True every DH frame. Returns the axes."""
    import matplotlib.pyplot as plt

    if ax is None:
        fig = plt.figure(figsize=(5, 5))
        ax = fig.add_subplot(projection="3d")
    origins = model.fkine_all(q)[:, :3, 3]
    tool = model.fkine(q)
    points = np.vstack([origins, tool[:3, 3]])
    ax.plot(points[:, 0], points[:, 1], points[:, 2], "-o", color=color, lw=3, ms=4, label=label)
    span = max(0.1, float(np.ptp(points, axis=0).max()))
    length = 0.15 * span
    shown = model.fkine_all(q) if frames else [tool]
    for pose in shown:
        for k, c in enumerate(("r", "g", "b")):
            end = pose[:3, 3] + length * pose[:3, k]
            ax.plot(*zip(pose[:3, 3], end), color=c, lw=1)
    centre = points.mean(axis=0)
    reach = max(span, 0.2) * 0.7
    ax.set_xlim(centre[0] - reach, centre[0] + reach)
    ax.set_ylim(centre[1] - reach, centre[1] + reach)
    ax.set_zlim(max(0.0, centre[2] - reach), centre[2] + reach)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_zlabel("z (m)")
    return ax


def panel_view(rig, width=800, height=500):
    """The lab panel of a private rig started with panel=True, as an IPython IFrame (its 3D view
    follows the arm live). Open the URL in a browser when the notebook server is remote."""
    from IPython.display import IFrame

    url = rig.panel_url()
    if not url:
        raise ValueError("this rig runs no panel: start it with sirupp.start_rig(panel=True)")
    return IFrame(url, width=width, height=height)


def plot_recording(recording, joints=None, ax=None):
    """Set-point and virtual arm per joint against time, in degrees (revolute joints)."""
    import matplotlib.pyplot as plt

    n = recording.q.shape[1] if recording.q.ndim == 2 else 0
    joints = range(n) if joints is None else joints
    if ax is None:
        _, ax = plt.subplots(figsize=(7, 3.5))
    for j in joints:
        line, = ax.plot(recording.t, np.degrees(recording.q[:, j]), label="j%d virtual" % (j + 1))
        ax.plot(recording.t, np.degrees(recording.q_setpoint[:, j]), "--", color=line.get_color(),
                label="j%d set-point" % (j + 1))
    ax.set_xlabel("sim time (s)")
    ax.set_ylabel("angle (deg)")
    ax.legend(fontsize="small", ncol=2)
    return ax
