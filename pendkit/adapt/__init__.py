"""Fitting the kit to one rig in a few episodes of its time (`pendkit adapt`): excitation episodes, the
rig's twin identified from its encoder alone, a policy trained on that twin from the robust one, greedy
episodes and fine-tuning on the rig, and the classical controllers designed on the same twin."""
