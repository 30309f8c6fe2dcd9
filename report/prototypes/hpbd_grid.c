// Hierarchical PBD (Mueller 2008) on the two-corner cloth of two_corner_cloth.c (2D, 100 x 100, 5 px,
// g 980, 1/64 s steps). Levels: every other grid line kept (plus the last), down to 3 x 3; coarse
// particles carry the fine masses by bilinear weights; coarse sticks join neighbours of the coarse
// grid and only resist stretching (unilateral); after a level is swept its corrections are
// interpolated (bilinear) to the next finer level's particles that are not on it. Per substep:
// coarsest level first, the fine level (bilateral, colour order) last. argv[1] = 1: hung by the top row.
// Build and run: gcc -O2 hpbd_grid.c -lm -o hpbd_grid && ./hpbd_grid 0 && ./hpbd_grid 1
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#define W 100
#define H 100
#define NP (W * H)
#define MAXL 8
typedef struct { double x, y; } V;
static V x[NP], xp[NP], before[NP];
static double w[NP];
static int TOPROW = 0;
static const double L = 5.0, G = 980.0;
static int idx(int c, int r) { return r * W + c; }
// level grid lines
static int ncol[MAXL], nrow[MAXL], cols[MAXL][W], rows[MAXL][H], nlev;
static double wl[MAXL][NP];  // inverse masses per level (indexed by particle)
static void build_levels(void) {
  ncol[0] = W; nrow[0] = H;
  for (int c = 0; c < W; c++) cols[0][c] = c;
  for (int r = 0; r < H; r++) rows[0][r] = r;
  nlev = 1;
  while (ncol[nlev - 1] > 3 && nlev < MAXL) {
    int l = nlev, n = 0;
    for (int i = 0; i < ncol[l - 1]; i += 2) cols[l][n++] = cols[l - 1][i];
    if (cols[l][n - 1] != cols[l - 1][ncol[l - 1] - 1]) cols[l][n++] = cols[l - 1][ncol[l - 1] - 1];
    ncol[l] = n; n = 0;
    for (int i = 0; i < nrow[l - 1]; i += 2) rows[l][n++] = rows[l - 1][i];
    if (rows[l][n - 1] != rows[l - 1][nrow[l - 1] - 1]) rows[l][n++] = rows[l - 1][nrow[l - 1] - 1];
    nrow[l] = n; nlev++;
  }
}
// position of grid line g in level l's list, and the bracketing pair for a finer line
static void bracket(const int *lines, int n, int g, int *i0, int *i1, double *t) {
  int k = 0; while (k + 1 < n && lines[k + 1] <= g) k++;
  if (lines[k] == g || k + 1 >= n) { *i0 = *i1 = lines[k]; *t = 0; return; }
  *i0 = lines[k]; *i1 = lines[k + 1]; *t = (double)(g - lines[k]) / (lines[k + 1] - lines[k]);
}
static int on_level(int l, int c, int r) {
  int a = 0, b = 0;
  for (int i = 0; i < ncol[l]; i++) a |= cols[l][i] == c;
  for (int i = 0; i < nrow[l]; i++) b |= rows[l][i] == r;
  return a && b;
}
// interpolation table for level l-1 particles not on level l: 4 parents and weights
typedef struct { int p[4]; double wt[4]; int child; } Interp;
static Interp *interp[MAXL]; static int ninterp[MAXL];
static void build_interp(void) {
  for (int l = 1; l < nlev; l++) {
    interp[l] = malloc(sizeof(Interp) * NP); ninterp[l] = 0;
    for (int ri = 0; ri < nrow[l - 1]; ri++) for (int ci = 0; ci < ncol[l - 1]; ci++) {
      int c = cols[l - 1][ci], r = rows[l - 1][ri];
      if (on_level(l, c, r)) continue;
      int c0, c1, r0, r1; double tc, tr;
      bracket(cols[l], ncol[l], c, &c0, &c1, &tc); bracket(rows[l], nrow[l], r, &r0, &r1, &tr);
      Interp it = {{idx(c0, r0), idx(c1, r0), idx(c0, r1), idx(c1, r1)}, {(1 - tc) * (1 - tr), tc * (1 - tr), (1 - tc) * tr, tc * tr}, idx(c, r)};
      interp[l][ninterp[l]++] = it;
    }
  }
}
static void init(void) {
  for (int r = 0; r < H; r++) for (int c = 0; c < W; c++) {
    int i = idx(c, r); x[i] = (V){c * L, -r * L}; xp[i] = x[i];
    w[i] = (r == 0 && (TOPROW || c == 0 || c == W - 1)) ? 0 : 1;
  }
  // masses per level: coarse particles gather their children's masses by the weights
  static double mass[NP];
  for (int i = 0; i < NP; i++) { mass[i] = 1; wl[0][i] = w[i]; }
  for (int l = 1; l < nlev; l++) {
    for (int k = 0; k < ninterp[l]; k++) {
      Interp *it = &interp[l][k];
      for (int q = 0; q < 4; q++) mass[it->p[q]] += it->wt[q] * mass[it->child];
    }
    for (int i = 0; i < NP; i++) wl[l][i] = w[i] == 0 ? 0 : 1 / mass[i];
  }
}
static void predict(double h) {
  for (int i = 0; i < NP; i++) {
    if (w[i] == 0) continue;
    V v = {x[i].x - xp[i].x, x[i].y - xp[i].y}; xp[i] = x[i];
    x[i].x += v.x; x[i].y += v.y - G * h * h;
  }
}
static void project(int a, int b, double rest, const double *iw, int unilateral) {
  double dx = x[b].x - x[a].x, dy = x[b].y - x[a].y, d = sqrt(dx * dx + dy * dy), ws = iw[a] + iw[b];
  if (ws == 0 || (unilateral && d <= rest)) return;
  double lam = -(d - rest) / ws, nx = dx / d, ny = dy / d;
  x[a].x -= iw[a] * nx * lam; x[a].y -= iw[a] * ny * lam; x[b].x += iw[b] * nx * lam; x[b].y += iw[b] * ny * lam;
}
static void sweep_level(int l) {
  int nc = ncol[l], nr = nrow[l];
  for (int par = 0; par < 2; par++) for (int ri = 0; ri < nr; ri++) for (int ci = par; ci + 1 < nc; ci += 2)
    project(idx(cols[l][ci], rows[l][ri]), idx(cols[l][ci + 1], rows[l][ri]), (cols[l][ci + 1] - cols[l][ci]) * L, wl[l], l > 0);
  for (int par = 0; par < 2; par++) for (int ri = par; ri + 1 < nr; ri += 2) for (int ci = 0; ci < nc; ci++)
    project(idx(cols[l][ci], rows[l][ri]), idx(cols[l][ci], rows[l][ri + 1]), (rows[l][ri + 1] - rows[l][ri]) * L, wl[l], l > 0);
}
static int LEVELS_USED;  // how many coarse levels take part (0 = plain sweep)
static void hierarchy(void) {
  int top = LEVELS_USED < nlev - 1 ? LEVELS_USED : nlev - 1;
  for (int l = top; l >= 1; l--) {
    // remember level-l positions, sweep, then carry the change to level l-1's other particles
    for (int ri = 0; ri < nrow[l]; ri++) for (int ci = 0; ci < ncol[l]; ci++) { int i = idx(cols[l][ci], rows[l][ri]); before[i] = x[i]; }
    sweep_level(l);
    for (int k = 0; k < ninterp[l]; k++) {
      Interp *it = &interp[l][k]; V d = {0, 0};
      for (int q = 0; q < 4; q++) { d.x += it->wt[q] * (x[it->p[q]].x - before[it->p[q]].x); d.y += it->wt[q] * (x[it->p[q]].y - before[it->p[q]].y); }
      if (w[it->child] != 0) { x[it->child].x += d.x; x[it->child].y += d.y; }
    }
  }
  sweep_level(0);
}
static double strain_max(void) {
  double m = 0;
  for (int r = 0; r < H; r++) for (int c = 0; c < W; c++) {
    if (c > 0) m = fmax(m, hypot(x[idx(c, r)].x - x[idx(c - 1, r)].x, x[idx(c, r)].y - x[idx(c - 1, r)].y) / L - 1);
    if (r > 0) m = fmax(m, hypot(x[idx(c, r)].x - x[idx(c, r - 1)].x, x[idx(c, r)].y - x[idx(c, r - 1)].y) / L - 1);
  }
  return m;
}
static double base_ms;
static void run(int substeps, int levels) {
  LEVELS_USED = levels; init();
  double h = 1.0 / 64 / substeps, falling = 0, hanging = 0;
  clock_t t0 = clock();
  for (int step = 1; step <= 320; step++) {
    for (int s = 0; s < substeps; s++) { predict(h); hierarchy(); }
    double m = strain_max();
    if (!isfinite(m) || m > 1e6) { falling = hanging = INFINITY; break; }
    if (step > 256) hanging = fmax(hanging, m); else falling = fmax(falling, m);
  }
  double ms = 1000.0 * (clock() - t0) / CLOCKS_PER_SEC / 320;
  if (base_ms == 0) base_ms = ms;
  printf("%s S=%3d coarse levels %d | falling %9.3g %% hanging %9.3g %% | %.1fx\n", TOPROW ? "top row    " : "two corners", substeps, levels, falling * 100, hanging * 100, ms / base_ms);
  fflush(stdout);
}
int main(int argc, char **argv) {
  TOPROW = argc > 1 ? atoi(argv[1]) : 0;
  build_levels(); build_interp();
  printf("levels:"); for (int l = 0; l < nlev; l++) printf(" %dx%d", ncol[l], nrow[l]); printf("\n");
  run(8, 0); run(16, 0); run(32, 0);
  for (int lv = 1; lv <= 6; lv++) run(8, lv);
  run(4, 6); run(16, 6);
  return 0;
}
