#pragma once
// HT index arithmetic (internal). Everything is integer grid coordinates in the
// cube [0, L]^3, L = 2^k. See docs/ht.md and spec/tlod-format.md §2:
//  - a diamond is keyed by its centre, the midpoint of the spine its tets share;
//    every grid point except the 8 cube corners is the centre of one diamond;
//  - tets are ordered vertex 4-tuples refined by Maubach's tagged bisection.
#include <array>
#include <bit>
#include <cstdint>

namespace tetlod::ht {

using Pt = std::array<int32_t, 3>;
using Tet = std::array<Pt, 4>;

inline Pt midpoint(const Pt& a, const Pt& b) {
    return {(a[0] + b[0]) / 2, (a[1] + b[1]) / 2, (a[2] + b[2]) / 2};
}

inline int trailing_zeros(int32_t v, int k) { return v == 0 ? k : std::countr_zero(uint32_t(v)); }

struct DiamondInfo {
    int cls = 0;      // 0: cube centre, 1: face centre, 2: edge midpoint
    int t = 0;        // h = 2^t, the half-side of the diamond's cube
    int32_t h = 1;
    int level = 0;    // level of the diamond's tets
    int odd_mask = 0; // bit a set when coordinate a is an odd multiple of h
    bool corner = false;
};

/// Classifies a grid point of [0, L]^3 as a diamond centre (spec/tlod-format.md §2).
inline DiamondInfo classify_centre(const Pt& c, int k) {
    DiamondInfo d;
    int tz[3] = {trailing_zeros(c[0], k), trailing_zeros(c[1], k), trailing_zeros(c[2], k)};
    d.t = std::min(tz[0], std::min(tz[1], tz[2]));
    if (d.t >= k) {
        d.corner = true;
        return d;
    }
    d.h = int32_t{1} << d.t;
    int odd = 0;
    for (int a = 0; a < 3; ++a)
        if (tz[a] == d.t) d.odd_mask |= 1 << a, ++odd;
    d.cls = 3 - odd;
    d.level = 3 * (k - 1 - d.t) + d.cls;
    return d;
}

/// +1 when c_a + h is a multiple of 4h (the neighbour at +h is "even"), else -1.
inline int32_t parity_sign(int32_t ca, int32_t h) { return ((ca + h) % (4 * h)) == 0 ? 1 : -1; }

inline bool in_cube(const Pt& p, int32_t L) {
    return p[0] >= 0 && p[1] >= 0 && p[2] >= 0 && p[0] <= L && p[1] <= L && p[2] <= L;
}

/// Parents of a diamond: the diamonds whose split creates its tets. Returns the
/// count (<= 4); points outside the cube are dropped.
inline int diamond_parents(const Pt& c, const DiamondInfo& d, int32_t L, Pt out[4]) {
    int n = 0;
    // Cube corners are not diamonds: the root diamond's formula points at them.
    auto add = [&](Pt p) {
        if (!in_cube(p, L)) return;
        const bool corner = (p[0] == 0 || p[0] == L) && (p[1] == 0 || p[1] == L) &&
                            (p[2] == 0 || p[2] == L);
        if (!corner) out[n++] = p;
    };
    const int32_t h = d.h, s = 2 * h;
    if (d.cls == 0) {
        Pt e;
        int32_t sig[3];
        for (int a = 0; a < 3; ++a) sig[a] = parity_sign(c[a], h), e[a] = c[a] + h * sig[a];
        for (int a = 0; a < 3; ++a) {
            Pt p = e;
            p[a] -= s * sig[a];
            add(p);
        }
    } else if (d.cls == 1) {
        int a = 0;
        while (d.odd_mask & (1 << a)) ++a;  // the normal axis is the even one
        Pt p = c, q = c;
        p[a] += h, q[a] -= h;
        add(p), add(q);
    } else {
        int a = std::countr_zero(unsigned(d.odd_mask));  // the edge axis
        for (int i = 0; i < 3; ++i) {
            if (i == a) continue;
            Pt p = c, q = c;
            p[i] += h, q[i] -= h;
            add(p), add(q);
        }
    }
    return n;
}

/// Tets of a diamond as (spine end, spine end, other, other). Tets with a vertex
/// outside the cube are dropped (boundary diamonds are incomplete). Returns the
/// count (<= 8).
inline int diamond_tets(const Pt& c, const DiamondInfo& d, int32_t L, Tet out[8]) {
    int n = 0;
    auto add = [&](const Pt& a, const Pt& b, const Pt& u, const Pt& v) {
        if (in_cube(a, L) && in_cube(b, L) && in_cube(u, L) && in_cube(v, L))
            out[n++] = Tet{a, b, u, v};
    };
    const int32_t h = d.h, s = 2 * h;
    if (d.cls == 0) {
        int32_t sig[3];
        Pt e, o;
        for (int a = 0; a < 3; ++a) {
            sig[a] = parity_sign(c[a], h);
            e[a] = c[a] + h * sig[a];
            o[a] = c[a] - h * sig[a];
        }
        static constexpr int kOrders[6][2] = {{0, 1}, {0, 2}, {1, 0}, {1, 2}, {2, 0}, {2, 1}};
        for (const auto& ord : kOrders) {
            Pt u = e;
            u[ord[0]] -= s * sig[ord[0]];
            Pt v = u;
            v[ord[1]] -= s * sig[ord[1]];
            add(e, o, u, v);
        }
    } else if (d.cls == 1) {
        int a = 0;
        while (d.odd_mask & (1 << a)) ++a;
        const int b = (a + 1) % 3, b2 = (a + 2) % 3;
        const int32_t sb = parity_sign(c[b], h), sb2 = parity_sign(c[b2], h);
        Pt P = c, Q = c, R1 = c, R2 = c;
        P[b] += h * sb, P[b2] += h * sb2;
        Q[b] -= h * sb, Q[b2] -= h * sb2;
        R1[b] += h * sb, R1[b2] -= h * sb2;
        R2[b] -= h * sb, R2[b2] += h * sb2;
        for (int side = -1; side <= 1; side += 2) {
            Pt C = c;
            C[a] += side * h;
            add(P, Q, R1, C);
            add(P, Q, R2, C);
        }
    } else {
        const int a = std::countr_zero(unsigned(d.odd_mask));
        Pt A = c, B = c;
        A[a] -= h, B[a] += h;
        for (int i = 0; i < 3; ++i) {
            if (i == a) continue;
            const int j = 3 - a - i;
            for (int si = -1; si <= 1; si += 2) {
                Pt F = c;
                F[i] += si * h;
                for (int sj = -1; sj <= 1; sj += 2) {
                    Pt C = F;
                    C[j] += sj * h;
                    add(A, B, F, C);
                }
            }
        }
    }
    return n;
}

/// Children of a diamond (the diamonds its split can make splittable); count <= 8.
inline int diamond_children(const Pt& c, const DiamondInfo& d, int32_t L, Pt out[8]) {
    int n = 0;
    auto add = [&](Pt p) {
        if (in_cube(p, L)) out[n++] = p;
    };
    const int32_t h = d.h;
    if (d.cls == 0) {
        for (int a = 0; a < 3; ++a)
            for (int sg = -1; sg <= 1; sg += 2) {
                Pt p = c;
                p[a] += sg * h;
                add(p);
            }
    } else if (d.cls == 1) {
        for (int a = 0; a < 3; ++a) {
            if (!(d.odd_mask & (1 << a))) continue;
            for (int sg = -1; sg <= 1; sg += 2) {
                Pt p = c;
                p[a] += sg * h;
                add(p);
            }
        }
    } else if (h >= 2) {
        const int32_t g = h / 2;
        for (int m = 0; m < 8; ++m)
            add(Pt{c[0] + ((m & 1) ? g : -g), c[1] + ((m & 2) ? g : -g), c[2] + ((m & 4) ? g : -g)});
    }
    return n;
}

// ---- Maubach's ordered bisection (docs/ht.md) -------------------------------

/// A tet of the hierarchy as an ordered 4-tuple with tag j in {1,2,3}; the
/// spine (longest edge) is v[0]-v[j].
struct MTet {
    Tet v;
    uint8_t tag;
    uint8_t level;
};

/// The 6 roots: Kuhn paths 0 -> L e_p -> L(e_p + e_q) -> (L,L,L).
inline void maubach_roots(int32_t L, MTet out[6]) {
    static constexpr int kPerm[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2},
                                        {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
    for (int r = 0; r < 6; ++r) {
        Pt p0{0, 0, 0}, p1 = p0, p2, p3{L, L, L};
        p1[kPerm[r][0]] = L;
        p2 = p1;
        p2[kPerm[r][1]] = L;
        out[r] = MTet{Tet{p0, p1, p2, p3}, 3, 0};
    }
}

inline Pt maubach_centre(const MTet& t) { return midpoint(t.v[0], t.v[t.tag]); }

inline void maubach_bisect(const MTet& t, MTet& c1, MTet& c2) {
    const int j = t.tag;
    const Pt z = maubach_centre(t);
    const uint8_t tag = j == 1 ? 3 : uint8_t(j - 1);
    const uint8_t level = uint8_t(t.level + 1);
    // child 1: (x0 .. x(j-1), z, x(j+1) .. x3); child 2: (x1 .. xj, z, x(j+1) .. x3)
    c1.v = t.v;
    c1.v[j] = z;
    // spelled out per tag: a loop with a variable bound compiles to a slow memmove
    switch (j) {
        case 3: c2.v = Tet{t.v[1], t.v[2], t.v[3], z}; break;
        case 2: c2.v = Tet{t.v[1], t.v[2], z, t.v[3]}; break;
        default: c2.v = Tet{t.v[1], z, t.v[2], t.v[3]}; break;
    }
    c1.tag = c2.tag = tag;
    c1.level = c2.level = level;
}

// ---- exact predicates ------------------------------------------------------

inline int64_t orient(const Pt& a, const Pt& b, const Pt& c, const Pt& d) {
    const int64_t b0 = b[0] - a[0], b1 = b[1] - a[1], b2 = b[2] - a[2];
    const int64_t c0 = c[0] - a[0], c1 = c[1] - a[1], c2 = c[2] - a[2];
    const int64_t d0 = d[0] - a[0], d1 = d[1] - a[1], d2 = d[2] - a[2];
    return b0 * (c1 * d2 - c2 * d1) - b1 * (c0 * d2 - c2 * d0) + b2 * (c0 * d1 - c1 * d0);
}

inline int64_t dist2(const Pt& a, const Pt& b) {
    const int64_t x = a[0] - b[0], y = a[1] - b[1], z = a[2] - b[2];
    return x * x + y * y + z * z;
}

}  // namespace tetlod::ht
