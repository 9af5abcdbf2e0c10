"""The project: one immutable document of everything the artist makes on a clip, its file
format, and the project-level steps that the command and the app both call."""
