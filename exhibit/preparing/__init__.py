"""What the kiosk prepares while the first scene plays (layer 7, above the framing it uses and
below the kiosk): the jobs, one scene with its meshes at every mesh level and its timelines
framed (jobs.py); the preparers that run them inline or in a niced worker process
(preparing.py, process_preparer.py, worker.py, worker_watch.py); and the meshes as they arrive
(scene_meshes.py). `exhibit prepare` runs the same jobs to fill the mesh cache."""
