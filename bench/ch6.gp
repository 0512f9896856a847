# ch6.gp — charts of the thesis's ch. 6.5 photon-map experiments from bench_ch6_photonmap's
# tab-separated tables (--dat) and images (--image-dir), with the thesis's own measurements
# (bench/ch6_thesis.dat) as dashed lines. Run by pipelines/ch6.mk:
#
#   gnuplot -e "dat='out/ch6'; res='docs/results'; thesis='bench/ch6_thesis.dat'" bench/ch6.gp
#
# Writes into res: ch6-build.png (Table 6.2), ch6-knn-k.png (Table 6.3), ch6-knn-size.png
# (Table 6.4), ch6-eps.png (Table 6.5 and image error against kNN time) and ch6-fig6.8.png
# (the classic estimate for each ε, Fig. 6.8). Our times are in s (build) and ms (queries); the
# thesis's file is in s throughout.

set terminal pngcairo size 1100,600 font "sans,10"
set datafile separator "\t"
set key outside right top
set grid
# One colour per library, in the order of knn_indices.h: ANN kd, ANN bd, FLANN randomized 1 tree,
# FLANN randomized 4 trees, FLANN single (pf::PhotonMap), nanoflann.
set linetype 1 lc rgb "#9400d3"
set linetype 2 lc rgb "#009e73"
set linetype 3 lc rgb "#56b4e9"
set linetype 4 lc rgb "#e69f00"
set linetype 5 lc rgb "#d62728"
set linetype 6 lc rgb "#0072b2"
# The thesis's rows, by column of ch6_thesis.dat (2..5), take the colour of our row with the same
# library and settings (ANN kd 1, ANN bd 2, FLANN default randomized kd-trees 4, FLANN single 5).
tcolor(j) = word("1 2 4 5", j - 1) + 0
tname(j) = j == 2 ? "ANN kd" : j == 3 ? "ANN bd" : j == 4 ? "FLANN randomized kd" : "FLANN single"
thesis_title(j) = "thesis 2015: " . tname(j)

set output res . "/ch6-build.png"
set title "Table 6.2: photon-map build time vs map size (one thread)"
set xlabel "photons in the map"
set ylabel "build time (s)"
set logscale y
plot for [i=2:*] dat . "/ch6-build.dat" using 1:i with linespoints lc i-1 lw 2 pt 7 \
       title columnheader(i), \
     for [j=2:5] thesis index 0 using 1:j with linespoints lc tcolor(j) dt 2 pt 6 \
       title thesis_title(j)

set output res . "/ch6-knn-k.png"
set title "Table 6.3: time of one k-nearest query vs k (map of 500,000 photons, one thread)"
set xlabel "k (nearest photons)"
set ylabel "time per query (ms)"
set logscale xy
plot for [i=2:*] dat . "/ch6-knn-k.dat" using 1:i with linespoints lc i-1 lw 2 pt 7 \
       title columnheader(i), \
     for [j=2:5] thesis index 1 using 1:(1e3 * column(j)) with linespoints lc tcolor(j) dt 2 \
       pt 6 title thesis_title(j)

set output res . "/ch6-knn-size.png"
set title "Table 6.4: time of one 5,000-nearest query vs map size (one thread)"
set xlabel "photons in the map"
set ylabel "time per query (ms)"
unset logscale x
set logscale y
plot for [i=2:*] dat . "/ch6-knn-size.dat" using 1:i with linespoints lc i-1 lw 2 pt 7 \
       title columnheader(i), \
     for [j=2:5] thesis index 2 using 1:(1e3 * column(j)) with linespoints lc tcolor(j) dt 2 \
       pt 6 title thesis_title(j)

# Left: Fig. 6.9 / Table 6.5, query time vs ε. Right: image error of the classic estimate
# (pf::PhotonMap, FLANN single kd) against its query time, one point per ε.
set terminal pngcairo size 1300,550 font "sans,10"
set output res . "/ch6-eps.png"
set multiplot layout 1,2
set title "Table 6.5: time of one 5,000-nearest query vs ε (map of 500,000)"
set xlabel "ε (approximate search)"
set ylabel "time per query (ms)"
set key inside right top font "sans,8"
unset logscale x
set logscale y
plot for [i=2:*] dat . "/ch6-knn-eps.dat" using 1:i with linespoints lc i-1 lw 2 pt 7 \
       title columnheader(i), \
     for [j=2:5] thesis index 3 using 1:(1e3 * column(j)) with linespoints lc tcolor(j) dt 2 \
       pt 6 title thesis_title(j)
set title "Fig. 6.8: image error vs query time, classic estimate (k = 5,000)"
set xlabel "time per query, pf::PhotonMap (ms)"
set ylabel "relative RMSE against ε = 0 (%)"
unset logscale
set key off
set offsets graph 0.05, graph 0.2, graph 0.1, 0
set yrange [0:*]
# The query times of pf::PhotonMap at each ε (its column in ch6-knn-eps.dat) joined to the
# image errors (ch6-eps-image.dat: ε, estimate time, RMSE, relative RMSE) by row: both list the
# same ε in the same order.
knn = dat . "/ch6-knn-eps.dat"
pm_col = int(system("head -1 " . knn . " | tr '\\t' '\\n' | grep -n 'pf::PhotonMap' | cut -d: -f1"))
rel_col = int(system("head -1 " . knn . " | awk -F'\\t' '{print NF}'")) + 4
plot "< paste " . knn . " " . dat . "/ch6-eps-image.dat" \
       using pm_col:(100 * column(rel_col)) every ::1 with linespoints lc 5 lw 2 pt 7, \
     "" using pm_col:(100 * column(rel_col)):(sprintf("ε = %g", column(1))) \
       every ::1 with labels offset 1.5, 0.8 left
unset multiplot

# Fig. 6.8: the estimate for each ε side by side (same exposure).
eps_list = system("tail -n +2 " . dat . "/ch6-eps-image.dat | cut -f1 | tr '\\n' ' '")
n = words(eps_list)
set terminal pngcairo size 240 * n, 300 font "sans,10"
set output res . "/ch6-fig6.8.png"
set multiplot layout 1, n title "Fig. 6.8: classic photon mapping, indirect light, k = 5,000 nearest, approximate search with ε"
unset border
unset tics
unset key
unset grid
unset offsets
set yrange [*:*]
unset xlabel
unset ylabel
set size ratio -1
do for [e in eps_list] {
  set title "ε = " . e
  plot dat . "/ch6-eps-" . e . ".png" binary filetype=png with rgbimage
}
unset multiplot
