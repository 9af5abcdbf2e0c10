"""Stage 1, footage: video files, animated GIFs and image folders as frame sources."""
