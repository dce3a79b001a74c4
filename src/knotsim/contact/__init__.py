"""Contact between rod edges: broad phase, edge-edge distance, IMC contact potential, smooth friction."""
