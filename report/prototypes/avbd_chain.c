// AVBD (Giles, Diaz, Yuksel 2025) on the prototype chain of chain_direct.c: 100 links of 0.1 m, unit
// masses, 1000:1 tip, pinned at the top, g = 9.81, 1/64 s steps; against one in-order GS sweep per
// substep (the crate's sweep) at 8 substeps. Per-particle 2x2 block Newton (VBD) with augmented
// Lagrangian hard distance constraints, diagonally lumped geometric stiffness, warm start
// lambda *= alpha*gamma, penalty *= gamma (clamped), penalty ramp beta*|C|, stabilisation C - alpha*C0,
// adaptive initial guess; the parameters of the authors' 2D demo (alpha 0.99, gamma 0.99, beta 1e5,
// penalty 1e3..1e9). Scenes: hanging from rest (total stretch after 3 s), released from horizontal
// (largest link strain over 4 s), and a 1 m pendulum at 90 deg (energy after 10 s, velocities from
// the last step). Cost as CPU time per step relative to the sweep at 8 substeps in the same run.
// Build and run: gcc -O2 avbd_chain.c -lm -o avbd_chain && ./avbd_chain
#include <math.h>
#include <stdio.h>
#include <time.h>
#define MAXN 101
typedef struct { double x, y; } V;
static int N = 100;
static V x[MAXN + 1], v[MAXN + 1], vprev[MAXN + 1], y[MAXN + 1], x0[MAXN + 1], xp[MAXN + 1];
static double m[MAXN + 1], w[MAXN + 1], lam[MAXN], pen[MAXN], C0[MAXN];
static double L = 0.1, ALPHA = 0.99, GAMMA = 0.99, BETA = 1e5, PMIN = 1e3, PMAX = 1e9;
static const double G = 9.81;
static void init(int horizontal, double tip, int n, double len) {
  N = n; L = len;
  for (int i = 0; i <= N; i++) {
    x[i] = horizontal ? (V){i * L, 0} : (V){0, -i * L}; xp[i] = x[i];
    v[i] = vprev[i] = (V){0, 0}; m[i] = 1; w[i] = 1;
  }
  m[0] = INFINITY; w[0] = 0; m[N] = tip; w[N] = 1 / tip;
  for (int j = 0; j < N; j++) { lam[j] = 0; pen[j] = PMIN; }
}
static double dist(int j, V *n) {
  double dx = x[j + 1].x - x[j].x, dy = x[j + 1].y - x[j].y, d = sqrt(dx * dx + dy * dy);
  n->x = dx / d; n->y = dy / d; return d;
}
static void avbd_step(double h, int iters) {
  V n;
  for (int j = 0; j < N; j++) { C0[j] = dist(j, &n) - L; lam[j] *= ALPHA * GAMMA; pen[j] = fmin(fmax(pen[j] * GAMMA, PMIN), PMAX); }
  for (int i = 1; i <= N; i++) {
    y[i] = (V){x[i].x + v[i].x * h, x[i].y + v[i].y * h - G * h * h};
    double ay = (v[i].y - vprev[i].y) / h, wgt = fmin(fmax(-ay / G, 0), 1);
    x0[i] = x[i];
    x[i] = (V){x[i].x + v[i].x * h, x[i].y + v[i].y * h - G * wgt * h * h};
  }
  for (int it = 0; it < iters; it++) {
    for (int i = 1; i <= N; i++) {
      double k = m[i] / (h * h);
      double a11 = k, a12 = 0, a22 = k, r1 = k * (x[i].x - y[i].x), r2 = k * (x[i].y - y[i].y);
      for (int side = 0; side < 2; side++) {
        int j = side == 0 ? i - 1 : i;  // constraint j joins j and j+1
        if (j < 0 || j >= N) continue;
        double d = dist(j, &n), C = d - L - ALPHA * C0[j], f = pen[j] * C + lam[j];
        double sgn = side == 0 ? 1 : -1;  // particle i is the b end of j = i-1, the a end of j = i
        double Jx = sgn * n.x, Jy = sgn * n.y;
        // Hessian of |xb - xa| w.r.t. either end: (I - n n^T)/d; lumped by column norms
        double h11 = (1 - n.x * n.x) / d, h12 = -n.x * n.y / d, h22 = (1 - n.y * n.y) / d;
        double g1 = sqrt(h11 * h11 + h12 * h12), g2 = sqrt(h12 * h12 + h22 * h22);
        r1 += Jx * f; r2 += Jy * f;
        a11 += pen[j] * Jx * Jx + g1 * fabs(f); a12 += pen[j] * Jx * Jy; a22 += pen[j] * Jy * Jy + g2 * fabs(f);
      }
      double det = a11 * a22 - a12 * a12;
      x[i].x -= (a22 * r1 - a12 * r2) / det; x[i].y -= (a11 * r2 - a12 * r1) / det;
    }
    for (int j = 0; j < N; j++) {
      double C = dist(j, &n) - L - ALPHA * C0[j];
      lam[j] = pen[j] * C + lam[j];
      pen[j] = fmin(pen[j] + BETA * fabs(C), PMAX);
    }
  }
  for (int i = 1; i <= N; i++) { vprev[i] = v[i]; v[i] = (V){(x[i].x - x0[i].x) / h, (x[i].y - x0[i].y) / h}; }
}
static void gs_step(double h, int substeps) {
  double hs = h / substeps;
  for (int s = 0; s < substeps; s++) {
    for (int i = 1; i <= N; i++) { V vel = {x[i].x - xp[i].x, x[i].y - xp[i].y}; xp[i] = x[i]; x[i].x += vel.x; x[i].y += vel.y - G * hs * hs; }
    for (int j = 0; j < N; j++) {
      V n; double d = dist(j, &n), ws = w[j] + w[j + 1], l = -(d - L) / ws;
      x[j].x -= w[j] * n.x * l; x[j].y -= w[j] * n.y * l; x[j + 1].x += w[j + 1] * n.x * l; x[j + 1].y += w[j + 1] * n.y * l;
    }
  }
  for (int i = 1; i <= N; i++) v[i] = (V){(x[i].x - xp[i].x) / hs, (x[i].y - xp[i].y) / hs};
}
static double total_stretch(void) { double s = 0; V n; for (int j = 0; j < N; j++) s += dist(j, &n); return s / (N * L) - 1; }
static double max_link(void) { double s = 0; V n; for (int j = 0; j < N; j++) s = fmax(s, dist(j, &n) / L - 1); return s; }
static double energy(void) { double e = 0; for (int i = 1; i <= N; i++) e += 0.5 * m[i] * (v[i].x * v[i].x + v[i].y * v[i].y) + m[i] * G * x[i].y; return e; }
static double gs_ms; static int SUB = 1;
static void avbd_sub(double h, int iters) { for (int s = 0; s < SUB; s++) avbd_step(h / SUB, iters); }
static void scenes(int avbd, int substeps_or_iters) {
  double h = 1.0 / 64;
  clock_t t0 = clock();
  init(0, 1000, 100, 0.1);
  for (int s = 0; s < 192; s++) avbd ? avbd_sub(h, substeps_or_iters) : gs_step(h, substeps_or_iters);
  double hang = total_stretch();
  init(1, 1000, 100, 0.1);
  double swing = 0;
  for (int s = 0; s < 256; s++) { avbd ? avbd_sub(h, substeps_or_iters) : gs_step(h, substeps_or_iters); swing = fmax(swing, max_link()); }
  double ms = 1000.0 * (clock() - t0) / CLOCKS_PER_SEC / 448;
  // pendulum: 1 m, unit mass, released horizontal; energy relative to the fall's potential (E(0) = 0, bottom -g)
  init(1, 1, 1, 1.0);
  for (int s = 0; s < 640; s++) avbd ? avbd_sub(h, substeps_or_iters) : gs_step(h, substeps_or_iters);
  // energy kept: (E + m g L) / (m g L), 1 = all kept
  double kept = (energy() + G) / G;
  if (!avbd && substeps_or_iters == 8) gs_ms = ms;
  printf("%-5s x%d %s=%3d | hanging total stretch %9.4f %% | swinging max link %10.4f %% | pendulum energy kept %6.3f | %.3f ms/step (%.1fx GS 8x1)\n",
         avbd ? "AVBD" : "GS", avbd ? SUB : 1, avbd ? "iterations" : "substeps  ", substeps_or_iters, hang * 100, swing * 100, kept, ms, ms / gs_ms);
  fflush(stdout);
}
int main(void) {
  scenes(0, 8);
  scenes(0, 64);
  int its[] = {1, 2, 4, 8, 16, 32}, subs[] = {1, 1, 2, 4, 8};
  double betas[] = {1e5, 1e8, 1e8, 1e8, 1e8};
  for (int c = 0; c < 5; c++) {
    BETA = betas[c]; SUB = subs[c];
    printf("beta %g, %d step(s) of 1/%d s per frame\n", BETA, SUB, 64 * SUB);
    for (int i = 0; i < 6; i++) scenes(1, its[i]);
  }
  return 0;
}
