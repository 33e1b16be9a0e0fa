<?xml version="1.0" encoding="UTF-8"?>
<!-- cityatlas test fixture, hand-written (GPL-3.0-or-later). Well-formed XML whose root is SVG, not CityGML. -->
<svg xmlns="http://www.w3.org/2000/svg" width="100" height="80" viewBox="0 0 100 80">
  <rect id="building" x="10" y="10" width="50" height="40" fill="#c86"/>
  <polygon id="roof" points="10,10 35,0 60,10" fill="#844"/>
</svg>
