"""`pendkit queue`: a class's rigs shared by a queue. Teams submit jobs (a controller or policy judged on a rig
by the kit's rule, or `pendkit adapt`'s excitation recorded); runners on one or several machines take them
for free rigs of the job's servo, reset the rig between episodes and store the results; a page served by the
kit shows every rig and job live and a leaderboard.

The queue's state lives in a database through SQLAlchemy Core: an SQLite file by default, PostgreSQL by URL
when runners on several machines share it (`store.py`). Which job a free rig takes is decided in `fair.py`.
"""
