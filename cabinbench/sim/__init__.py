"""The simulation one env steps: pymunk physics, the lidar, the coverage raster, the cleaning
protocol, the world that ties them together, the observation, rewards and rendering."""
