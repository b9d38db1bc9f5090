"""Reinforcement-learning agents (torch, CPU-first): DQN and its GRU-encoded variant, a replay buffer, and a
synchronous trainer. Install with `pip install -e ".[rl]"` (CPU PyTorch first: see the README)."""
