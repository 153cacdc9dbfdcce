/* The replay file compiled into the image (RLG_REPLAY_PATH, given by the build). */
    .section .rodata.rlg_replay, "a"
    .balign 4
    .global rlg_replay
rlg_replay:
    .incbin RLG_REPLAY_PATH
    .global rlg_replay_end
rlg_replay_end:
