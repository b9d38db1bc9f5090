"""The env's registered name and its episode length: light enough to import before MuJoCo is needed."""

ENV_ID = "pendkit/SwingUp-v0"
EPISODE_STEPS = 500
