"""Data with known truth: simulated shaking-table recordings and the paper's reference cases."""
