// Hierarchical PBD built from the stick graph alone (what the crate would build: no grid, no rest
// geometry). Level l+1 = a maximal independent set of level l (pins first, then index order);
// every other particle is interpolated from its coarse neighbours (weights ~ 1/length); a coarse
// edge joins two coarse neighbours of one fine particle with max length = the two lengths' sum
// (a unilateral "no longer than the path" constraint, exact along a straight line); coarse masses
// gather the children's by the weights. Per substep: coarsest level first, fine (bilateral, colour
// order) last. Scene: two_corner_cloth.c's 100 x 100 cloth (or hung by its top row: argv[1] = 1).
// argv[2] = 1: coarse max lengths from the build-time (rest) distance instead of the path length;
// 2: only coarse edges whose path is straight at build time (no shear stiffness added).
// Build and run: gcc -O2 hpbd_graph.c -lm -o hpbd_graph && ./hpbd_graph 0 0 (1 0, 0 1, 1 1)
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#define W 100
#define H 100
#define NP (W * H)
#define MAXL 12
#define MAXE (4 * NP)
typedef struct { double x, y; } V;
typedef struct { int a, b; double len; } E;
typedef struct { int child, n, p[8]; double wt[8]; } Interp;
static V x[NP], xp[NP], before[NP];
static double w[NP], mass[NP], wl[MAXL][NP];
static int REST_GEOM, TOPROW, nlev, nnodes[MAXL], nodes[MAXL][NP], nedges[MAXL], ninterp[MAXL];
static E *edges[MAXL];
static Interp *interp[MAXL];
static const double L = 5.0, G = 980.0;
static int idx(int c, int r) { return r * W + c; }
static int cmp_e(const void *p, const void *q) { const E *a = p, *b = q; return a->a != b->a ? a->a - b->a : a->b != b->b ? a->b - b->b : (a->len > b->len) - (a->len < b->len); }
static void pins(void) { for (int r = 0; r < H; r++) for (int c = 0; c < W; c++) w[idx(c, r)] = (r == 0 && (TOPROW || c == 0 || c == W - 1)) ? 0 : 1; }
static void build(void) {
  pins();
  for (int r = 0; r < H; r++) for (int c = 0; c < W; c++) x[idx(c, r)] = (V){c * L, -r * L};
  edges[0] = malloc(sizeof(E) * MAXE); int k = 0;
  for (int par = 0; par < 2; par++) for (int r = 0; r < H; r++) for (int c = par; c + 1 < W; c += 2) edges[0][k++] = (E){idx(c, r), idx(c + 1, r), L};
  for (int par = 0; par < 2; par++) for (int r = par; r + 1 < H; r += 2) for (int c = 0; c < W; c++) edges[0][k++] = (E){idx(c, r), idx(c, r + 1), L};
  nedges[0] = k; nnodes[0] = NP; for (int i = 0; i < NP; i++) nodes[0][i] = i;
  static int adjn[NP], adj[NP][16]; static double adjl[NP][16]; static char coarse[NP];
  for (nlev = 1; nlev < MAXL && nnodes[nlev - 1] > 8; nlev++) {
    int l = nlev;
    for (int i = 0; i < nnodes[l - 1]; i++) adjn[nodes[l - 1][i]] = 0;
    for (int e = 0; e < nedges[l - 1]; e++) {
      E ed = edges[l - 1][e];
      if (adjn[ed.a] < 16) { adj[ed.a][adjn[ed.a]] = ed.b; adjl[ed.a][adjn[ed.a]++] = ed.len; }
      if (adjn[ed.b] < 16) { adj[ed.b][adjn[ed.b]] = ed.a; adjl[ed.b][adjn[ed.b]++] = ed.len; }
    }
    memset(coarse, 0, sizeof coarse);
    for (int pass = 0; pass < 2; pass++) for (int i = 0; i < nnodes[l - 1]; i++) {
      int n = nodes[l - 1][i], ok = (pass == 0) == (w[n] == 0);
      if (!ok) continue;
      int free_ = 1; for (int q = 0; q < adjn[n]; q++) free_ &= !coarse[adj[n][q]];
      if (free_ || w[n] == 0) coarse[n] = 1;
    }
    nnodes[l] = 0; for (int i = 0; i < nnodes[l - 1]; i++) if (coarse[nodes[l - 1][i]]) nodes[l][nnodes[l]++] = nodes[l - 1][i];
    interp[l] = malloc(sizeof(Interp) * NP); ninterp[l] = 0;
    edges[l] = malloc(sizeof(E) * MAXE); int ne = 0;
    for (int i = 0; i < nnodes[l - 1]; i++) {
      int n = nodes[l - 1][i]; if (coarse[n]) continue;
      Interp it = {n, 0, {0}, {0}}; double sum = 0;
      for (int q = 0; q < adjn[n]; q++) if (coarse[adj[n][q]] && it.n < 8) { it.p[it.n] = adj[n][q]; it.wt[it.n] = 1 / adjl[n][q]; sum += it.wt[it.n]; it.n++; }
      for (int q = 0; q < it.n; q++) it.wt[q] /= sum;
      if (it.n) interp[l][ninterp[l]++] = it;
      for (int q = 0; q < adjn[n]; q++) for (int s = q + 1; s < adjn[n]; s++) {
        int a = adj[n][q], b = adj[n][s];
        if (!coarse[a] || !coarse[b] || ne >= MAXE) continue;
        if (a > b) { int t = a; a = b; b = t; }
        double len = adjl[n][q] + adjl[n][s];
        double rest = hypot(x[b].x - x[a].x, x[b].y - x[a].y);  // build-time (rest) distance
        if (REST_GEOM == 2 && rest < 0.99 * len) continue;  // 2: only straight paths
        if (REST_GEOM == 1) len = rest;
        edges[l][ne++] = (E){a, b, len};
      }
    }
    qsort(edges[l], ne, sizeof(E), cmp_e);
    int m = 0; for (int e = 0; e < ne; e++) if (m == 0 || edges[l][m - 1].a != edges[l][e].a || edges[l][m - 1].b != edges[l][e].b) edges[l][m++] = edges[l][e];
    nedges[l] = m;
  }
}
static void init(void) {
  for (int r = 0; r < H; r++) for (int c = 0; c < W; c++) { int i = idx(c, r); x[i] = (V){c * L, -r * L}; xp[i] = x[i]; mass[i] = 1; }
  for (int i = 0; i < NP; i++) wl[0][i] = w[i];
  for (int l = 1; l < nlev; l++) {
    for (int k = 0; k < ninterp[l]; k++) { Interp *it = &interp[l][k]; for (int q = 0; q < it->n; q++) mass[it->p[q]] += it->wt[q] * mass[it->child]; }
    for (int i = 0; i < NP; i++) wl[l][i] = w[i] == 0 ? 0 : 1 / mass[i];
  }
}
static void predict(double h) {
  for (int i = 0; i < NP; i++) { if (w[i] == 0) continue; V v = {x[i].x - xp[i].x, x[i].y - xp[i].y}; xp[i] = x[i]; x[i].x += v.x; x[i].y += v.y - G * h * h; }
}
static void sweep(int l) {
  const double *iw = wl[l];
  for (int e = 0; e < nedges[l]; e++) {
    int a = edges[l][e].a, b = edges[l][e].b; double rest = edges[l][e].len;
    double dx = x[b].x - x[a].x, dy = x[b].y - x[a].y, d = sqrt(dx * dx + dy * dy), ws = iw[a] + iw[b];
    if (ws == 0 || (l > 0 && d <= rest)) continue;
    double lam = -(d - rest) / ws, nx = dx / d, ny = dy / d;
    x[a].x -= iw[a] * nx * lam; x[a].y -= iw[a] * ny * lam; x[b].x += iw[b] * nx * lam; x[b].y += iw[b] * ny * lam;
  }
}
static int USE;
static void solve(void) {
  int top = USE < nlev - 1 ? USE : nlev - 1;
  for (int l = top; l >= 1; l--) {
    for (int i = 0; i < nnodes[l]; i++) before[nodes[l][i]] = x[nodes[l][i]];
    sweep(l);
    for (int k = 0; k < ninterp[l]; k++) {
      Interp *it = &interp[l][k]; V d = {0, 0};
      for (int q = 0; q < it->n; q++) { d.x += it->wt[q] * (x[it->p[q]].x - before[it->p[q]].x); d.y += it->wt[q] * (x[it->p[q]].y - before[it->p[q]].y); }
      if (w[it->child] != 0) { x[it->child].x += d.x; x[it->child].y += d.y; }
    }
  }
  sweep(0);
}
static double strain_max(void) { double m = 0; for (int e = 0; e < nedges[0]; e++) { E ed = edges[0][e]; m = fmax(m, hypot(x[ed.b].x - x[ed.a].x, x[ed.b].y - x[ed.a].y) / L - 1); } return m; }
static double base_ms;
static void run(int substeps, int levels) {
  USE = levels; init();
  double h = 1.0 / 64 / substeps, falling = 0, hanging = 0;
  clock_t t0 = clock();
  for (int step = 1; step <= 320; step++) {
    for (int s = 0; s < substeps; s++) { predict(h); solve(); }
    double m = strain_max();
    if (!isfinite(m) || m > 1e6) { falling = hanging = INFINITY; break; }
    if (step > 256) hanging = fmax(hanging, m); else falling = fmax(falling, m);
  }
  double ms = 1000.0 * (clock() - t0) / CLOCKS_PER_SEC / 320;
  if (base_ms == 0) base_ms = ms;
  printf("%s S=%3d coarse levels %2d | falling %9.3g %% hanging %9.3g %% | %.2f ms/step, %.1fx\n", TOPROW ? "top row    " : "two corners", substeps, levels, falling * 100, hanging * 100, ms, ms / base_ms);
  fflush(stdout);
}
int main(int argc, char **argv) {
  TOPROW = argc > 1 ? atoi(argv[1]) : 0; REST_GEOM = argc > 2 ? atoi(argv[2]) : 0;
  build();
  printf("levels (particles/edges):"); for (int l = 0; l < nlev; l++) printf(" %d/%d", nnodes[l], nedges[l]); printf("\n");
  run(8, 0); run(16, 0); run(32, 0);
  for (int lv = 1; lv < nlev; lv++) run(8, lv);
  run(16, nlev);
  return 0;
}
