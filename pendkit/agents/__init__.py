"""Reinforcement-learning agents (torch, CPU-first): DQN, TD3 and their trained-GRU versions R-DQN and R-TD3
behind one contract (`base.py`), the learner registry (`learners.py`), runs and weights (`runs.py`), replay,
and the synchronous and non-blocking trainers. Install with `pip install -e ".[rl]"` (CPU PyTorch first: see
the README)."""
