"""render(): the tissue's particles and the tool's points as shaded dots in a side view
(looking along -z: x to the right, y up), numpy only."""

import numpy as np

WIDTH, HEIGHT = 240, 160


def render_points(groups, spacing, lower=(-0.06, -0.01), upper=(0.06, 0.07)):
    """An (HEIGHT, WIDTH, 3) uint8 picture of `groups`: [(points (N, 3), colour (3,))], drawn
    in order, farther points (smaller z) first, each as a dot as wide as the particles'
    `spacing` [m] (at least 2 pixels) shaded by its depth."""
    image = np.full((HEIGHT, WIDTH, 3), 245, np.uint8)
    scale = min(WIDTH / (upper[0] - lower[0]), HEIGHT / (upper[1] - lower[1]))
    dot = max(2, int(round(spacing * scale)))
    for points, colour in groups:
        p = np.asarray(points, np.float64).reshape(-1, 3)
        if len(p) == 0:
            continue
        order = np.argsort(p[:, 2], kind="stable")
        p = p[order]
        shade = 0.6 + 0.4 * (p[:, 2] - p[:, 2].min()) / max(np.ptp(p[:, 2]), 1e-9)
        c = np.clip(np.outer(shade, colour), 0, 255).astype(np.uint8)
        u = ((p[:, 0] - lower[0]) * scale).astype(int)
        v = (HEIGHT - 1 - (p[:, 1] - lower[1]) * scale).astype(int)
        for du in range(dot):
            for dv in range(dot):
                ok = (u + du >= 0) & (u + du < WIDTH) & (v - dv >= 0) & (v - dv < HEIGHT)
                image[v[ok] - dv, u[ok] + du] = c[ok]
    return image


def box_points(center, half, spacing=0.002):
    """Points on the faces of an axis-aligned box (a tool drawn as its outline)."""
    axes = [np.arange(-h, h + 1e-12, spacing) if h > spacing else np.array([0.0]) for h in half]
    g = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    return np.asarray(center) + g
