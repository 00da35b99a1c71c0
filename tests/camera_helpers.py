"""A pinhole camera over a flat wall, for the tests of reprojection and of temporal stability."""
import numpy as np

from gmcpt.temporal.history import fit_projection

WIDTH, HEIGHT = 24, 16


def camera(centre, yaw_degrees=0.0, focal=20.0):
    """A pinhole at ``centre`` looking down -z (turned by ``yaw``): film coordinates -> (origins, directions)."""
    yaw = np.radians(yaw_degrees)
    turn = np.array([[np.cos(yaw), 0, np.sin(yaw)], [0, 1, 0], [-np.sin(yaw), 0, np.cos(yaw)]])

    def rays(film):
        local = np.stack([(film[:, 0] - WIDTH / 2) / focal, -(film[:, 1] - HEIGHT / 2) / focal,
                          -np.ones(len(film))], axis=1)
        directions = local @ turn.T
        return np.tile(centre, (len(film), 1)).astype(float), directions / np.linalg.norm(directions, axis=1)[:, None]
    return rays


def centres():
    rows, columns = np.mgrid[0:HEIGHT, 0:WIDTH]
    return np.stack([columns.ravel() + 0.5, rows.ravel() + 0.5], axis=1).astype(float)


def wall_frame(rays, wall_z=-5.0):
    """A frame of a wall at z = wall_z seen through ``rays``: the projection, hit points, normals."""
    film = centres()
    origins, directions = rays(film)
    t = (wall_z - origins[:, 2]) / directions[:, 2]
    positions = origins + directions * t[:, None]
    normals = np.tile([0.0, 0.0, 1.0], (len(film), 1))
    return fit_projection(film, origins, directions, WIDTH, HEIGHT), positions, normals
