<?xml version="1.0" encoding="UTF-8"?>
<!-- cityatlas test fixture, hand-written (GPL-3.0-or-later). An lod2Solid refers to its faces by xlink:href; one href names an id that does not exist. -->
<CityModel xmlns="http://www.opengis.net/citygml/2.0" xmlns:gml="http://www.opengis.net/gml" xmlns:bldg="http://www.opengis.net/citygml/building/2.0" xmlns:app="http://www.opengis.net/citygml/appearance/2.0" xmlns:xlink="http://www.w3.org/1999/xlink" xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" xsi:schemaLocation="http://www.opengis.net/citygml/2.0 http://schemas.opengis.net/citygml/profiles/base/2.0/CityGML.xsd">
  <gml:boundedBy>
    <gml:Envelope srsName="urn:ogc:def:crs:EPSG::25832" srsDimension="3">
      <gml:lowerCorner>690000.0 5336000.0 500.0</gml:lowerCorner>
      <gml:upperCorner>690030.0 5336008.0 506.0</gml:upperCorner>
    </gml:Envelope>
  </gml:boundedBy>
  <cityObjectMember>
    <bldg:Building gml:id="B_xlink">
      <bldg:lod2Solid>
        <gml:Solid gml:id="B_xlink_solid">
          <gml:exterior>
            <gml:CompositeSurface>
              <gml:surfaceMember xlink:href="#B_xlink_ground"/>
              <gml:surfaceMember xlink:href="#B_xlink_wall_s"/>
              <gml:surfaceMember xlink:href="#B_xlink_wall_e"/>
              <gml:surfaceMember xlink:href="#B_xlink_wall_n"/>
              <gml:surfaceMember xlink:href="#B_xlink_wall_w"/>
              <gml:surfaceMember xlink:href="#B_xlink_roof"/>
              <gml:surfaceMember xlink:href="#POLY_does_not_exist"/>
            </gml:CompositeSurface>
          </gml:exterior>
        </gml:Solid>
      </bldg:lod2Solid>
      <bldg:boundedBy>
        <bldg:GroundSurface gml:id="B_xlink_ground_surface">
          <bldg:lod2MultiSurface>
            <gml:MultiSurface>
              <gml:surfaceMember>
                <gml:Polygon gml:id="B_xlink_ground">
                  <gml:exterior>
                    <gml:LinearRing gml:id="B_xlink_ground_ring">
                      <gml:posList srsDimension="3">690000.00 5336000.00 500.00 690000.00 5336008.00 500.00 690010.00 5336008.00 500.00 690010.00 5336000.00 500.00 690000.00 5336000.00 500.00</gml:posList>
                    </gml:LinearRing>
                  </gml:exterior>
                </gml:Polygon>
              </gml:surfaceMember>
            </gml:MultiSurface>
          </bldg:lod2MultiSurface>
        </bldg:GroundSurface>
      </bldg:boundedBy>
      <bldg:boundedBy>
        <bldg:WallSurface gml:id="B_xlink_wall_s_surface">
          <bldg:lod2MultiSurface>
            <gml:MultiSurface>
              <gml:surfaceMember>
                <gml:Polygon gml:id="B_xlink_wall_s">
                  <gml:exterior>
                    <gml:LinearRing gml:id="B_xlink_wall_s_ring">
                      <gml:posList srsDimension="3">690000.00 5336000.00 500.00 690010.00 5336000.00 500.00 690010.00 5336000.00 506.00 690000.00 5336000.00 506.00 690000.00 5336000.00 500.00</gml:posList>
                    </gml:LinearRing>
                  </gml:exterior>
                </gml:Polygon>
              </gml:surfaceMember>
            </gml:MultiSurface>
          </bldg:lod2MultiSurface>
        </bldg:WallSurface>
      </bldg:boundedBy>
      <bldg:boundedBy>
        <bldg:WallSurface gml:id="B_xlink_wall_e_surface">
          <bldg:lod2MultiSurface>
            <gml:MultiSurface>
              <gml:surfaceMember>
                <gml:Polygon gml:id="B_xlink_wall_e">
                  <gml:exterior>
                    <gml:LinearRing gml:id="B_xlink_wall_e_ring">
                      <gml:posList srsDimension="3">690010.00 5336000.00 500.00 690010.00 5336008.00 500.00 690010.00 5336008.00 506.00 690010.00 5336000.00 506.00 690010.00 5336000.00 500.00</gml:posList>
                    </gml:LinearRing>
                  </gml:exterior>
                </gml:Polygon>
              </gml:surfaceMember>
            </gml:MultiSurface>
          </bldg:lod2MultiSurface>
        </bldg:WallSurface>
      </bldg:boundedBy>
      <bldg:boundedBy>
        <bldg:WallSurface gml:id="B_xlink_wall_n_surface">
          <bldg:lod2MultiSurface>
            <gml:MultiSurface>
              <gml:surfaceMember>
                <gml:Polygon gml:id="B_xlink_wall_n">
                  <gml:exterior>
                    <gml:LinearRing gml:id="B_xlink_wall_n_ring">
                      <gml:posList srsDimension="3">690010.00 5336008.00 500.00 690000.00 5336008.00 500.00 690000.00 5336008.00 506.00 690010.00 5336008.00 506.00 690010.00 5336008.00 500.00</gml:posList>
                    </gml:LinearRing>
                  </gml:exterior>
                </gml:Polygon>
              </gml:surfaceMember>
            </gml:MultiSurface>
          </bldg:lod2MultiSurface>
        </bldg:WallSurface>
      </bldg:boundedBy>
      <bldg:boundedBy>
        <bldg:WallSurface gml:id="B_xlink_wall_w_surface">
          <bldg:lod2MultiSurface>
            <gml:MultiSurface>
              <gml:surfaceMember>
                <gml:Polygon gml:id="B_xlink_wall_w">
                  <gml:exterior>
                    <gml:LinearRing gml:id="B_xlink_wall_w_ring">
                      <gml:posList srsDimension="3">690000.00 5336008.00 500.00 690000.00 5336000.00 500.00 690000.00 5336000.00 506.00 690000.00 5336008.00 506.00 690000.00 5336008.00 500.00</gml:posList>
                    </gml:LinearRing>
                  </gml:exterior>
                </gml:Polygon>
              </gml:surfaceMember>
            </gml:MultiSurface>
          </bldg:lod2MultiSurface>
        </bldg:WallSurface>
      </bldg:boundedBy>
      <bldg:boundedBy>
        <bldg:RoofSurface gml:id="B_xlink_roof_surface">
          <bldg:lod2MultiSurface>
            <gml:MultiSurface>
              <gml:surfaceMember>
                <gml:Polygon gml:id="B_xlink_roof">
                  <gml:exterior>
                    <gml:LinearRing gml:id="B_xlink_roof_ring">
                      <gml:posList srsDimension="3">690000.00 5336000.00 506.00 690010.00 5336000.00 506.00 690010.00 5336008.00 506.00 690000.00 5336008.00 506.00 690000.00 5336000.00 506.00</gml:posList>
                    </gml:LinearRing>
                  </gml:exterior>
                </gml:Polygon>
              </gml:surfaceMember>
            </gml:MultiSurface>
          </bldg:lod2MultiSurface>
        </bldg:RoofSurface>
      </bldg:boundedBy>
    </bldg:Building>
  </cityObjectMember>
</CityModel>
