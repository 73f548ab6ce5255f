//! Camera readers (being written)
