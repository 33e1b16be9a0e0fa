<?xml version="1.0" encoding="UTF-8"?>
<!-- cityatlas test fixture, hand-written (GPL-3.0-or-later). Well-formed XML whose root is GPX, not CityGML. -->
<gpx xmlns="http://www.topografix.com/GPX/1/1" version="1.1" creator="cityatlas-tests">
  <trk>
    <name>walk around the block</name>
    <trkseg>
      <trkpt lat="48.1500" lon="11.5800"><ele>500.0</ele></trkpt>
      <trkpt lat="48.1501" lon="11.5802"><ele>500.5</ele></trkpt>
    </trkseg>
  </trk>
</gpx>
