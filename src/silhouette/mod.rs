//! CPU silhouettes: an edge -> triangle adjacency built once per mesh, and per light a
//! brute-force, parallel pass over the edges.
