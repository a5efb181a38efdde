import numpy as np
import pytest
import torch
import torch.nn.functional as F

from latent_planner_ros.models import trilinear


@pytest.mark.parametrize("shape", [(4, 6, 3), (1, 2, 5)])
def test_sample_equals_grid_sample_inside_on_the_border_and_outside(rng, shape):
    torch.manual_seed(0)
    grid = torch.randn(5, *shape)
    cells = rng.uniform(-2.0, np.array(shape) + 1.0, size=(3000, 3))  # a third or so outside the grid
    cells[:10] = np.round(cells[:10])  # exactly on voxel centres
    cells[10:20] = -0.5  # half a voxel outside: zero padding takes half
    norm = (2.0 * cells + 1.0) / np.array(shape) - 1.0  # grid_sample's align_corners=False coordinates
    xyz = torch.as_tensor(norm[:, ::-1].copy(), dtype=torch.float32).reshape(1, -1, 1, 1, 3)  # it wants (z, y, x)
    expected = F.grid_sample(grid[None], xyz, mode="bilinear", padding_mode="zeros", align_corners=False)
    got = trilinear.sample(trilinear.channels_last(grid), shape, cells)
    assert got.shape == (3000, 5)
    torch.testing.assert_close(got, expected.reshape(5, -1).T, atol=1e-5, rtol=1e-5)
    far = trilinear.sample(trilinear.channels_last(grid), shape, np.full((2, 3), -5.0))
    assert torch.all(far == 0)
